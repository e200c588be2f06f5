"""Offline decoding of a LiDAR capture: ``python main.py decode lidar FILE.pcap [--lidar MODEL]
[--meta JSON]``.

:func:`read_pcap_udp` reads a classic libpcap file (either byte order, micro- or nanosecond
stamps; Ethernet with optional VLAN tags, Linux cooked capture or raw IPv4 links) and yields the
UDP datagrams. :func:`decode_pcap` feeds the data packets (Velodyne: port 2368, 1206 bytes;
Ouster: port 7502, 12 608 bytes for an OS1-64) through the same
:class:`~sensors.lidar_parser.LidarParser` the live receiver uses and yields one dict per
sweep, then a final ``{"counts": {...}, "rejects": {...}}``. :func:`iter_pcap_sweeps` yields
the sweeps' points themselves, one sweep at a time (for ``detect``).

The model is the config's ``lidar.model`` or the one given: ``vlp16`` (default), ``hdl32e``
or ``os1-64`` (an Ouster OS1 in the legacy packet format, with its metadata JSON file).
Packets from another model (another Velodyne, told by its product id and packet timing,
:mod:`sensors.velodyne_model`; an Ouster's or a Velodyne's packets when the other is
configured) are refused: counted as ``wrong_model``, by model in ``refused_models``, logged in
one line, never decoded.

``points_out`` receives every return of every decoded data packet as an (N, 4) float64 array:
x, y, z (m) in the SENSOR frame -- a Velodyne's as velodyne-decoder gives it (x forward =
azimuth 0, y left, z up, origin at the optical centre) with its reflectivity 0..255, an
Ouster's as ouster-sdk's ``XYZLut`` gives it by default (lidar-to-sensor transform and beam
origin offset included, :mod:`sensors.ouster`) with its signal (photons).
"""

from __future__ import annotations

import logging
import struct
from collections import Counter
from collections.abc import Iterator
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from common.car import CarConfig
from common.errors import DecodeError
from sensors.config import LidarConfig
from sensors.lidar_parser import LidarParser, SweepSource, open_model
from sensors.ouster import DATA_PORT as OUSTER_DATA_PORT
from sensors.ouster import IMU_PACKET_SIZE as OUSTER_IMU_PACKET_SIZE
from sensors.ouster import IMU_PORT as OUSTER_IMU_PORT
from sensors.ouster import legacy_beams_of_size
from sensors.velodyne import PACKET_SIZE, POSITION_PACKET_SIZE

log = logging.getLogger(__name__)

DATA_PORT = 2368
POSITION_PORT = 8308
_LINK_ETHERNET = 1
_LINK_RAW = (101, 12, 14)
_LINK_LINUX_SLL = 113


def read_pcap_udp(path: str | Path, counts: Counter[str] | None = None
                  ) -> Iterator[tuple[float, int, bytes]]:
    """Yield ``(timestamp_s, destination_port, payload)`` for each IPv4 UDP datagram.

    Frames that are not IPv4 UDP are counted in ``counts["not_udp"]``; a truncated record ends
    the file (``counts["truncated_record"]``). Raises :class:`DecodeError` if the file is not
    a classic pcap file.
    """
    counts = counts if counts is not None else Counter()
    data = Path(path).read_bytes()
    if len(data) < 24:
        raise DecodeError(f"{path}: too short for a pcap file ({len(data)} bytes)")
    magic = data[:4]
    if magic in (b"\xd4\xc3\xb2\xa1", b"\x4d\x3c\xb2\xa1"):
        endian = "<"
    elif magic in (b"\xa1\xb2\xc3\xd4", b"\xa1\xb2\x3c\x4d"):
        endian = ">"
    elif magic == b"\x0a\x0d\x0d\x0a":
        raise DecodeError(f"{path}: pcapng is not supported; convert it with "
                          "'editcap -F pcap IN OUT'")
    else:
        raise DecodeError(f"{path}: not a pcap file (magic {magic.hex()})")
    nanos = magic in (b"\x4d\x3c\xb2\xa1", b"\xa1\xb2\x3c\x4d")
    linktype = struct.unpack_from(endian + "I", data, 20)[0] & 0xFFFF
    record = struct.Struct(endian + "IIII")
    offset = 24
    while offset + 16 <= len(data):
        sec, frac, incl, _orig = record.unpack_from(data, offset)
        offset += 16
        if offset + incl > len(data):
            counts["truncated_record"] += 1
            return
        frame = data[offset:offset + incl]
        offset += incl
        stamp = sec + frac * (1e-9 if nanos else 1e-6)
        ip = _ip_payload(frame, linktype)
        udp = _udp_payload(ip) if ip is not None else None
        if udp is None:
            counts["not_udp"] += 1
            continue
        yield stamp, udp[0], udp[1]


def _ip_payload(frame: bytes, linktype: int) -> bytes | None:
    if linktype == _LINK_ETHERNET:
        pos = 12
        ethertype = int.from_bytes(frame[pos:pos + 2], "big")
        while ethertype in (0x8100, 0x88A8) and len(frame) >= pos + 6:  # VLAN tags
            pos += 4
            ethertype = int.from_bytes(frame[pos:pos + 2], "big")
        return frame[pos + 2:] if ethertype == 0x0800 else None
    if linktype == _LINK_LINUX_SLL:
        return frame[16:] if frame[14:16] == b"\x08\x00" else None
    if linktype in _LINK_RAW:
        return frame
    return None


def _udp_payload(ip: bytes) -> tuple[int, bytes] | None:
    if len(ip) < 20 or ip[0] >> 4 != 4 or ip[9] != 17:
        return None
    ihl = (ip[0] & 0x0F) * 4
    total = int.from_bytes(ip[2:4], "big")
    ip = ip[:total] if 0 < total <= len(ip) else ip
    udp = ip[ihl:]
    if len(udp) < 8:
        return None
    port = int.from_bytes(udp[2:4], "big")
    length = int.from_bytes(udp[4:6], "big")
    payload = udp[8:length] if 8 <= length <= len(udp) else udp[8:]
    return port, payload


def _datagrams(path: str | Path, counts: Counter[str]) -> Iterator[tuple[float, bytes]]:
    """The datagrams of a capture that may be a LiDAR's data packets (to the Velodyne's or the
    Ouster's port, or of their sizes), with their capture times; position and IMU packets and
    other traffic are only counted."""
    for stamp, port, payload in read_pcap_udp(path, counts):
        size = len(payload)
        if port == POSITION_PORT or size == POSITION_PACKET_SIZE:
            counts["position_packets"] += 1
        elif port == OUSTER_IMU_PORT or size == OUSTER_IMU_PACKET_SIZE:
            counts["imu_packets"] += 1
        elif (port in (DATA_PORT, OUSTER_DATA_PORT) or size == PACKET_SIZE
              or legacy_beams_of_size(size) is not None):
            counts["data_packets"] += 1
            yield stamp, payload
        else:
            counts["other_udp"] += 1


def decode_pcap(path: str, points_out: str | None = None,
                config: LidarConfig | None = None,
                car: CarConfig | None = None, model: str | None = None,
                meta_path: str | None = None) -> Iterator[dict[str, Any]]:
    """Decode a capture of the LiDAR ``model`` (default ``config.model``, the VLP-16; an
    Ouster needs ``meta_path`` or ``config.meta_file``): one dict per sweep, then
    ``{"counts": ..., "rejects": ...}`` (and ``"refused_models"`` when another sensor's packets
    were refused).

    Each sweep dict has ``time`` (end of the sweep, pcap clock, s), ``sweep_start``,
    ``points`` (returns in the sweep) and ``cones`` (detections in the VEHICLE frame:
    ``x_m``, ``y_m``, ``size``, ``height_m``, ``time``). Position and IMU packets and other
    datagrams are counted; data packets that do not decode are counted as rejects by reason.
    Raises :class:`~common.errors.ConfigError` (one line) for an unknown or undecoded model or
    a missing or bad metadata file.
    """
    config = config if config is not None else LidarConfig()
    config = replace(config, model=model or config.model,
                     meta_file=meta_path or config.meta_file)
    counts: Counter[str] = Counter()
    parser = LidarParser(config, car)
    all_points: list[np.ndarray] = []
    if points_out is not None:
        parser.on_packet = lambda _stamp, payload: all_points.append(
            parser.decoder.decode_points(payload))
    for stamp, payload in _datagrams(path, counts):
        for sweep in parser.feed(stamp, payload):
            yield _sweep_dict(sweep)
    for sweep in parser.flush():
        yield _sweep_dict(sweep)
    counts["sweeps"] = parser.counts["sweeps"]
    counts["points"] = parser.counts["points"]
    counts["cones"] = parser.counts["cones"]
    if points_out is not None:
        arr = np.concatenate(all_points) if all_points else np.zeros((0, 4))
        np.save(points_out, arr)
        counts["points_written"] = int(arr.shape[0])
    final: dict[str, Any] = {"counts": dict(sorted(counts.items())),
                             "rejects": dict(sorted(parser.rejects.items()))}
    refused = parser.refused
    if refused:
        final["refused_models"] = dict(sorted(refused.items()))
    yield final


Sweep = tuple[NDArray[np.float64], NDArray[np.int64], NDArray[np.float64], float]
"""One sweep of :func:`iter_pcap_sweeps`: points, rings, times_s, sweep_end_s."""


def iter_pcap_sweeps(path: str | Path, model_name: str, meta_path: str | Path | None = None,
                     *, cut_azimuth_deg: float = 180.0) -> Iterator[Sweep]:
    """The sweeps of a LiDAR capture, one at a time, every return of each (no window).

    ``model_name`` is a ``lidar.model`` name (``vlp16``, ``hdl32e``, ``os1-64``; see
    :mod:`sensors.lidar_models`); an Ouster needs its metadata JSON file ``meta_path``. Sweeps
    are cut where the azimuth passes ``cut_azimuth_deg`` (deg clockwise from x: 180, behind).
    Yields ``(points, rings, times_s, sweep_end_s)``:

    - ``points`` (N, 4) float64: x, y, z (m) in the SENSOR frame (Velodyne: velodyne-decoder's,
      x forward, y left, z up, origin at the optical centre; Ouster: ouster-sdk's ``XYZLut``
      sensor frame), intensity (a Velodyne's reflectivity 0..255, an Ouster's signal);
    - ``rings`` (N,) int64: the beam by elevation, 0 = the lowest;
    - ``times_s`` (N,) float64: each return's time (s), the sensor's own stamps mapped onto the
      capture's clock (pcap time);
    - ``sweep_end_s`` float: the time of the sweep's last return (s, the same clock).

    Packets of another model are refused and counted, bad ones rejected (logged, never raised).
    Raises :class:`~common.errors.ConfigError` for an unknown or undecoded model or a missing or
    bad metadata file, :class:`~common.errors.DecodeError` for a file that is not a pcap.
    """
    model, meta = open_model(model_name, None if meta_path is None else str(meta_path))
    source = SweepSource(model, meta, cut_azimuth_deg)
    counts: Counter[str] = Counter()
    for stamp, payload in _datagrams(path, counts):
        for sweep in source.feed(stamp, payload):
            yield sweep.points, sweep.rings, sweep.times_s, sweep.timestamp_s
    for sweep in source.flush():
        yield sweep.points, sweep.rings, sweep.times_s, sweep.timestamp_s
    if source.rejects:
        log.info("%s: %d data packets, rejected %s, refused %s", path, counts["data_packets"],
                 dict(source.rejects), dict(source.refused))


def _sweep_dict(sweep: Any) -> dict[str, Any]:
    return {
        "time": round(sweep.timestamp_s, 6),
        "sweep_start": round(sweep.sweep_start_s, 6),
        "points": sweep.point_count,
        "cones": [
            {"x_m": round(c.x_m, 3), "y_m": round(c.y_m, 3), "size": c.size.name.lower(),
             "height_m": round(c.height_m, 3), "time": round(c.timestamp_s, 6)}
            for c in sweep.cones
        ],
    }
