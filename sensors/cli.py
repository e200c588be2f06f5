"""``python main.py decode nmea|lidar|can FILE``: look at what a sensor sends.

Prints one JSON object per line per decoded reading, then one line ``{"counts": ..., "rejects":
...}``. GPS fixes carry ``lat`` and ``lon`` in degrees.

- ``decode nmea FILE``: a raw NMEA byte stream (a serial capture). Lines starting with ``#``
  (the comments of the gpsd test captures) are dropped; everything else is fed to the parser as
  bytes, in chunks, stamped with the time it would take to arrive at 9600 baud.
- ``decode lidar FILE.pcap [--points-out P.npy] [--lidar MODEL] [--meta JSON]``: LiDAR packets
  of ``--lidar`` (else the config's ``lidar.model``): VLP-16, HDL-32E, Ouster OS1-64 (legacy
  packets, beam angles from its metadata JSON ``--meta``) (sensors.decode_lidar).
- ``decode can FILE [--dbc D.dbc]``: candump / ASC / BLF logs (sensors.decode_can).
"""

from __future__ import annotations

import argparse
import importlib
import json
import math
import sys
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any

from common.json_values import json_ready
from common.messages import GpsFix

NMEA_CHUNK_BYTES = 64
"""Bytes per feed() call when decoding a capture (exercises the framing across chunks)."""
CAPTURE_BAUD = 9600
"""Line rate used to stamp capture bytes with a plausible arrival time (10 bits per byte)."""


def register(subparsers: Any, common: argparse.ArgumentParser) -> None:
    """Add ``decode`` with the kinds ``nmea``, ``lidar`` and ``can``."""
    parser = subparsers.add_parser(
        "decode", parents=[common],
        help="decode a sensor capture to JSON lines (nmea, lidar, can)")
    kinds = parser.add_subparsers(dest="kind", metavar="KIND", required=True)

    nmea = kinds.add_parser("nmea", parents=[common], help="NMEA 0183 byte stream (GPS)")
    nmea.add_argument("file", metavar="FILE", help="raw capture; '#' comment lines are skipped")
    nmea.set_defaults(func=_decode_nmea)

    lidar = kinds.add_parser("lidar", parents=[common],
                             help="LiDAR pcap (VLP-16, HDL-32E, Ouster OS1-64)")
    lidar.add_argument("file", metavar="FILE.pcap")
    lidar.add_argument("--points-out", metavar="P.npy", default=None,
                       help="write every return as an (N, 4) array x, y, z (m), intensity")
    lidar.add_argument("--lidar", metavar="MODEL", default=None,
                       help="the sensor: vlp16, hdl32e, os1-64 (default: the config's "
                            "sensors.lidar.model)")
    lidar.add_argument("--meta", metavar="JSON", default=None,
                       help="an Ouster's metadata file (beam angles, mode; default: the "
                            "config's sensors.lidar.meta_file)")
    lidar.set_defaults(func=_decode_lidar)

    can = kinds.add_parser("can", parents=[common], help="CAN log (candump, ASC, BLF)")
    can.add_argument("file", metavar="FILE")
    can.add_argument("--dbc", metavar="D.dbc", default=None,
                     help="DBC file (default: the car's sensors/car.dbc)")
    can.set_defaults(func=_decode_can)


def _emit(obj: dict[str, Any]) -> None:
    sys.stdout.write(json.dumps(json_ready(obj), allow_nan=False) + "\n")


def strip_comment_lines(data: bytes) -> bytes:
    """Drop the lines of ``data`` that start with ``#`` (gpsd capture comments); keep the rest
    byte for byte."""
    return b"".join(line for line in data.splitlines(keepends=True) if not line.startswith(b"#"))


def fix_to_json(fix: GpsFix) -> dict[str, Any]:
    """A fix as the JSON object ``decode nmea`` prints (degrees, metres, m/s)."""
    from common.conventions import enu_yaw_to_compass_deg

    utc = fix.utc_time_s
    time_text = None
    if math.isfinite(utc):
        hours, rest = divmod(utc, 3600.0)
        minutes, seconds = divmod(rest, 60.0)
        time_text = f"{int(hours):02d}:{int(minutes):02d}:{seconds:06.3f}"
    course_deg = (enu_yaw_to_compass_deg(fix.course_rad) if math.isfinite(fix.course_rad)
                  else math.nan)
    return {
        "class": "fix",
        "timestamp_s": round(fix.timestamp_s, 6),
        "time": time_text,
        "utc_time_s": utc,
        "lat": round(fix.lat_deg, 9),
        "lon": round(fix.lon_deg, 9),
        "alt": fix.altitude_m,
        "quality": fix.fix_quality,
        "sats": fix.satellites,
        "hdop": fix.hdop,
        "speed_mps": fix.speed_mps,
        "course_deg": course_deg,
        "course_rad": fix.course_rad,
    }


def decode_nmea_file(path: str | Path) -> Iterator[dict[str, Any]]:
    """Every fix of an NMEA capture as JSON-ready dicts, then one dict with ``counts``."""
    from sensors.nmea import NmeaParser

    data = strip_comment_lines(Path(path).read_bytes())
    parser = NmeaParser()
    seconds_per_byte = 10.0 / CAPTURE_BAUD
    for offset in range(0, len(data), NMEA_CHUNK_BYTES):
        chunk = data[offset:offset + NMEA_CHUNK_BYTES]
        stamp = (offset + len(chunk)) * seconds_per_byte
        for fix in parser.feed(stamp, chunk):
            yield fix_to_json(fix)
    for fix in parser.flush():
        yield fix_to_json(fix)
    yield {"counts": dict(parser.counts), "rejects": dict(parser.rejects),
           "talkers": dict(parser.talkers), "cycle_enders": sorted(parser.cycle_enders),
           "bytes": len(data)}


def _print_all(items: Iterable[dict[str, Any]]) -> int:
    try:
        for item in items:
            _emit(item)
        sys.stdout.flush()
    except BrokenPipeError:  # e.g. piped into `head`: stop quietly
        import os

        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
    return 0


def _check_file(path: str) -> bool:
    if not Path(path).is_file():
        print(f"error: {path}: no such file", file=sys.stderr)
        return False
    return True


def _decode_nmea(args: argparse.Namespace, config: object) -> int:
    if not _check_file(args.file):
        return 2
    return _print_all(decode_nmea_file(args.file))


def _load(module_name: str, function: str) -> Any:
    try:
        module = importlib.import_module(module_name)
    except ModuleNotFoundError as exc:
        if exc.name != module_name:
            raise
        print(f"error: {module_name} is not available in this build (module missing)",
              file=sys.stderr)
        return None
    func = getattr(module, function, None)
    if func is None:
        print(f"error: {module_name}.{function} is missing", file=sys.stderr)
    return func


def _decode_lidar(args: argparse.Namespace, config: object) -> int:
    if not _check_file(args.file):
        return 2
    if args.meta is not None and not _check_file(args.meta):
        return 2
    decode_pcap = _load("sensors.decode_lidar", "decode_pcap")
    if decode_pcap is None:
        return 2
    lidar_config = getattr(getattr(config, "sensors", None), "lidar", None)
    return _print_all(decode_pcap(args.file, args.points_out, lidar_config, None,
                                  args.lidar, args.meta))


def _decode_can(args: argparse.Namespace, config: object) -> int:
    if not _check_file(args.file):
        return 2
    if args.dbc is not None and not _check_file(args.dbc):
        return 2
    decode_log = _load("sensors.decode_can", "decode_log")
    if decode_log is None:
        return 2
    return _print_all(decode_log(args.file, args.dbc))
