"""Camera cone detections over UDP: the project's protobuf message (sensors/camera.proto).

The camera network runs in its own process on the car and sends one ``CameraCones`` datagram per
image: the image time, a frame counter and the cones it saw (vehicle frame, colour,
confidence). Regenerate ``camera_pb2.py`` after editing the schema with
``python -m grpc_tools.protoc -I sensors --python_out=sensors sensors/camera.proto``.
"""

from __future__ import annotations

import logging
import math
from collections import Counter
from dataclasses import replace

from google.protobuf.message import DecodeError as ProtoDecodeError
from google.protobuf.unknown_fields import UnknownFieldSet

from common.errors import DecodeError
from common.messages import CameraCones, ConeColour, ConeDetection
from sensors import camera_pb2
from sensors.config import CameraConfig

log = logging.getLogger(__name__)

MAX_DATAGRAM_BYTES = 65507
"""Largest UDP payload over IPv4."""


def encode_camera_cones(cc: CameraCones) -> bytes:
    """One datagram for ``cc``: positions as float32 (m), colour, confidence."""
    msg = camera_pb2.CameraCones(timestamp_s=cc.timestamp_s, frame_id=cc.frame_id & 0xFFFFFFFF)
    for cone in cc.cones:
        msg.cones.add(x_m=cone.x_m, y_m=cone.y_m, colour=int(cone.colour),
                      confidence=cone.confidence)
    data: bytes = msg.SerializeToString()
    if len(data) > MAX_DATAGRAM_BYTES:
        raise ValueError(f"CameraCones with {len(cc.cones)} cones does not fit in a datagram")
    return data


def decode_camera_cones(payload: bytes) -> CameraCones:
    """The :class:`CameraCones` in one datagram; :class:`DecodeError` if it is not one.

    Rejected: bytes that are not the protobuf message, a non-finite or negative time, cones
    with non-finite positions or a confidence outside 0..1, unknown colours.
    """
    msg = camera_pb2.CameraCones()
    try:
        msg.ParseFromString(payload)
    except (ProtoDecodeError, RuntimeError, ValueError) as exc:
        raise DecodeError(f"undecodable: not a CameraCones message ({exc})") from exc
    if not math.isfinite(msg.timestamp_s) or msg.timestamp_s < 0.0:
        raise DecodeError(f"bad_time: timestamp_s {msg.timestamp_s!r}")
    if len(UnknownFieldSet(msg)):
        raise DecodeError("undecodable: fields that are not in camera.proto")
    cones = []
    for c in msg.cones:
        if not (math.isfinite(c.x_m) and math.isfinite(c.y_m)):
            raise DecodeError("bad_cone: non-finite position")
        if not 0.0 <= c.confidence <= 1.0:
            raise DecodeError(f"bad_cone: confidence {c.confidence!r} outside 0..1")
        try:
            colour = ConeColour(c.colour)
        except ValueError:
            raise DecodeError(f"bad_cone: unknown colour {c.colour}") from None
        cones.append(ConeDetection(timestamp_s=msg.timestamp_s, x_m=float(c.x_m),
                                   y_m=float(c.y_m), colour=colour,
                                   confidence=float(c.confidence)))
    return CameraCones(timestamp_s=msg.timestamp_s, cones=tuple(cones), frame_id=msg.frame_id)


class CameraParser:
    """Camera datagrams in, :class:`CameraCones` out; bad datagrams counted in ``rejects``.

    ``feed(timestamp_s, payload)``: ``timestamp_s`` is the arrival time on our clock. A frame
    keeps its image time (plus ``sensors.camera.clock_offset_s``) when that is plausible: not
    after its arrival (20 ms of jitter allowed) and not more than ``max_latency_s`` before it.
    Otherwise the camera computer's clock is not ours, and its colour votes would be dropped as
    stale or wait for a future that never comes: the frame and its cones are restamped
    ``assumed_latency_s`` before arrival, counted in ``counts["restamped"]`` and logged, with
    the measured skew in :attr:`last_skew_s`. An empty datagram is rejected as ``empty``.
    """

    source = "camera"
    ARRIVAL_JITTER_S = 0.02
    """How far after its arrival an image time may be before it is implausible (s)."""

    def __init__(self, config: CameraConfig | None = None) -> None:
        cfg = config if config is not None else CameraConfig()
        self.clock_offset_s = cfg.clock_offset_s
        self.max_latency_s = cfg.max_latency_s
        self.assumed_latency_s = cfg.assumed_latency_s
        self.rejects: Counter[str] = Counter()
        self.counts: Counter[str] = Counter()
        self.last_skew_s = math.nan
        """Arrival time less image time of the last restamped frame (s)."""

    def feed(self, timestamp_s: float, payload: bytes) -> list[CameraCones]:
        """Decode one datagram; a bad one is counted, logged and gives nothing."""
        if not payload:
            self.rejects["empty"] += 1
            return []
        try:
            cc = decode_camera_cones(bytes(payload))
        except DecodeError as exc:
            reason = str(exc).split(":", 1)[0]
            self.rejects[reason] += 1
            if self.rejects[reason] <= 3 or self.rejects[reason] % 1000 == 0:
                log.warning("camera: rejected datagram (%s; %d so far)", exc,
                            self.rejects[reason])
            return []
        self.counts["frames"] += 1
        self.counts["cones"] += len(cc.cones)
        return [self._on_our_clock(cc, timestamp_s)]

    def _on_our_clock(self, cc: CameraCones, arrival_s: float) -> CameraCones:
        image_s = cc.timestamp_s + self.clock_offset_s
        latency_s = arrival_s - image_s
        if -self.ARRIVAL_JITTER_S <= latency_s <= self.max_latency_s:
            shift_s = self.clock_offset_s
        else:
            shift_s = arrival_s - self.assumed_latency_s - cc.timestamp_s
            self.last_skew_s = latency_s
            self.counts["restamped"] += 1
            n = self.counts["restamped"]
            if n <= 3 or n % 1000 == 0:
                log.warning("camera: image time %.3f s %s its arrival: the camera's clock is "
                            "not ours (set sensors.camera.clock_offset_s); stamped %.3f s "
                            "before arrival instead (%d frames so far)", abs(latency_s),
                            "before" if latency_s > 0 else "after", self.assumed_latency_s, n)
        if shift_s == 0.0:
            return cc
        return CameraCones(cc.timestamp_s + shift_s,
                           tuple(replace(c, timestamp_s=c.timestamp_s + shift_s)
                                 for c in cc.cones),
                           cc.frame_id)
