"""VLP-16 data packets to cone detections: model check, sweep assembly and the cone detector.

The same object serves the live UDP receiver, the simulation loop and replay: feed it each
datagram with its arrival time on the Clock and it returns a :class:`LidarCones` whenever a
sweep completes. Bad datagrams are counted in ``rejects`` by reason and logged, never raised;
well-formed packets from another Velodyne model (:mod:`sensors.velodyne_model`) are refused and
counted as ``wrong_model``.
"""

from __future__ import annotations

import logging
from collections import Counter
from collections.abc import Callable

from common.car import CarConfig
from common.errors import DecodeError
from common.messages import LidarCones, LidarPoints
from sensors.cone_detector import ConeDetector
from sensors.config import LidarConfig
from sensors.velodyne import SweepAssembler, check_packet, reject_reason
from sensors.velodyne_model import ModelGuard

log = logging.getLogger(__name__)


class LidarParser:
    """VLP-16 datagrams in, one :class:`LidarCones` per completed sweep out.

    ``feed(timestamp_s, payload)``: ``timestamp_s`` is the datagram's arrival time (s), taken
    as :data:`sensors.velodyne.PACKET_DURATION_S` after its first firing. ``rejects`` counts
    bad datagrams by reason (``bad_length``, ``bad_flag``, ``bad_azimuth``, ``wrong_model``:
    another sensor's packets, by model in ``guard.refused``); ``counts`` counts ``packets``,
    ``sweeps``, ``points`` and ``cones``. ``on_packet(timestamp_s, payload)``, when set, sees
    every packet that is decoded (a VLP-16's, in order). ``last_sweep`` keeps the last sweep's
    points (for drawing and tests): only those that can be part of a cone (the detector's
    :meth:`~sensors.cone_detector.ConeDetector.return_window`: the ground and the car's own
    body are left out while decoding), or every return with ``all_points``.
    """

    source = "lidar"

    def __init__(self, config: LidarConfig | None = None, car: CarConfig | None = None,
                 all_points: bool = False) -> None:
        config = config if config is not None else LidarConfig()
        self.detector = ConeDetector(config.detector, car if car is not None else CarConfig())
        window = None if all_points else self.detector.return_window()
        self.assembler = SweepAssembler(cut_azimuth_deg=config.cut_azimuth_deg,
                                        window=window)
        self.rejects: Counter[str] = Counter()
        self.counts: Counter[str] = Counter()
        self.last_sweep: LidarPoints | None = None
        self.guard: ModelGuard[tuple[float, bytes, tuple[int, ...]]] = ModelGuard(self.source)
        """Items: a packet's arrival time, payload and :func:`check_packet` fields."""
        self.on_packet: Callable[[float, bytes], None] | None = None

    def feed(self, timestamp_s: float, payload: bytes) -> list[LidarCones]:
        """Take one datagram; return the cones of the sweeps it completes (usually none)."""
        payload = bytes(payload)
        try:
            fields = check_packet(payload)
        except DecodeError as exc:
            reason = reject_reason(exc)
            self.rejects[reason] += 1
            if self.rejects[reason] <= 3 or self.rejects[reason] % 1000 == 0:
                log.warning("lidar: rejected datagram (%s; %d so far)", exc, self.rejects[reason])
            return []
        return self._assemble(self._admit(
            lambda: self.guard.admit((timestamp_s, payload, fields), payload)))

    def flush(self) -> list[LidarCones]:
        """Detect cones in the partial sweep collected so far (end of a file or a stream)."""
        out = self._assemble(self._admit(self.guard.flush))
        return out + [self._detect(s) for s in self.assembler.flush()]

    def _admit(self, decide: Callable[[], list[tuple[float, bytes, tuple[int, ...]]]]
               ) -> list[tuple[float, bytes, tuple[int, ...]]]:
        """Run the model guard; count what it refused."""
        refused = self.guard.refused_count
        admitted = decide()
        refused = self.guard.refused_count - refused
        if refused:
            self.rejects["wrong_model"] += refused
        return admitted

    def _assemble(self, admitted: list[tuple[float, bytes, tuple[int, ...]]]
                  ) -> list[LidarCones]:
        out: list[LidarCones] = []
        for timestamp_s, payload, fields in admitted:
            if self.on_packet is not None:
                self.on_packet(timestamp_s, payload)
            sweeps = self.assembler.add_checked(timestamp_s, payload, fields)
            self.counts["packets"] += 1
            if sweeps:
                out.extend(self._detect(s) for s in sweeps)
        return out

    def _detect(self, sweep: LidarPoints) -> LidarCones:
        self.last_sweep = sweep
        cones = self.detector.detect(sweep.points, sweep.rings, sweep.times_s, sweep.timestamp_s,
                                     sweep.return_count, sweep.start_s)
        self.counts["sweeps"] += 1
        self.counts["points"] += cones.point_count
        self.counts["cones"] += len(cones.cones)
        return cones
