"""Faults injected into a simulation: ``KIND@T[:DURATION]`` (seconds of simulated time).

Kinds:
- ``estop``: the remote emergency stop is pressed at T (RES frames over CAN report emergency).
- ``gps-dropout``: no GPS sentences from T (for DURATION, default for ever).
- ``lidar-dead``: no LiDAR packets from T.
- ``camera-dead``: no camera datagrams from T, so no cone colours (the cones the LiDAR sees
  stay of unknown colour).
- ``imu-nan``: IMU packets carry NaN values from T.
- ``can-garbage``: random CAN frames with unknown ids and wrong lengths are mixed in from T.

Examples: ``estop@30``, ``gps-dropout@12:5``, ``lidar-dead@40:2.5``, ``camera-dead@0``.
"""

from __future__ import annotations

import argparse
import math
import re
from collections.abc import Iterable
from dataclasses import dataclass

from common.errors import ConfigError

KINDS = ("estop", "gps-dropout", "lidar-dead", "camera-dead", "imu-nan", "can-garbage")

_PATTERN = re.compile(r"^\s*([a-z-]+)\s*@\s*([0-9.eE+-]+)\s*(?::\s*([0-9.eE+-]+|inf))?\s*$")


@dataclass(frozen=True, slots=True)
class Fault:
    """One fault: ``kind`` active from ``start_s`` for ``duration_s`` (inf: to the end)."""

    kind: str
    start_s: float
    duration_s: float = math.inf

    def active(self, t_s: float) -> bool:
        """Is the fault active at simulated time ``t_s``?"""
        return self.start_s <= t_s < self.start_s + self.duration_s

    def __str__(self) -> str:
        if math.isinf(self.duration_s):
            return f"{self.kind}@{self.start_s:g}"
        return f"{self.kind}@{self.start_s:g}:{self.duration_s:g}"


def parse_fault(text: str) -> Fault:
    """Parse ``KIND@T[:DURATION]``; raises :class:`ConfigError` naming what is wrong."""
    m = _PATTERN.match(text)
    if not m:
        raise ConfigError(f"fault {text!r}: expected KIND@T[:DURATION], e.g. 'estop@30' or"
                          f" 'gps-dropout@12:5' (kinds: {', '.join(KINDS)})")
    kind, start, duration = m.group(1), m.group(2), m.group(3)
    if kind not in KINDS:
        raise ConfigError(f"fault {text!r}: unknown kind {kind!r} (expected one of"
                          f" {', '.join(KINDS)})")
    try:
        start_s = float(start)
        duration_s = float(duration) if duration is not None else math.inf
    except ValueError:
        raise ConfigError(f"fault {text!r}: T and DURATION must be numbers (s)") from None
    if not math.isfinite(start_s) or start_s < 0.0:
        raise ConfigError(f"fault {text!r}: T must be a time >= 0 s")
    if math.isnan(duration_s) or duration_s <= 0.0:
        raise ConfigError(f"fault {text!r}: DURATION must be > 0 s")
    return Fault(kind, start_s, duration_s)


def fault_spec(text: str) -> str:
    """``--fault KIND@T[:DURATION]`` as an argparse type: checked with :func:`parse_fault` when
    the command line is read (one-line error), kept as the text."""
    try:
        parse_fault(text)
    except ConfigError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
    return text


def parse_faults(items: str | Iterable[str | Fault] | None) -> list[Fault]:
    """Faults from a comma-separated string, a list of strings (or Faults), or None."""
    if items is None:
        return []
    if isinstance(items, str):
        items = [p for p in items.split(",") if p.strip()]
    return [f if isinstance(f, Fault) else parse_fault(f) for f in items]
