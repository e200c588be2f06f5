"""When a GNSS fix was measured: its receive time less the receiver's latency.

A receiver reports a position some tens of milliseconds after it was measured (u-blox: about
0.1 s from the measurement to the end of the serial message), and the serial link adds a
jitter of its own. Applied at its receive time, a fix at 17 m/s lies 1.7 m behind the car.
:class:`GnssTiming` gives each fix the time it was measured:

- with ``from_utc``: its UTC time of day put on the receiving clock by the smallest
  (receive - UTC) offset seen so far (allowed to creep by :data:`CLOCK_DRIFT_ALLOWANCE` per
  second for the two clocks' drift; a jump of more than a second, e.g. a receiver restart,
  starts it again): the link's jitter is gone and what remains is the receiver's fastest
  delivery;
- then less ``latency_s``, the configured latency (of that fastest delivery with ``from_utc``).

Fixes without a UTC time keep their receive time (less the latency).
"""

from __future__ import annotations

import dataclasses
import math

from common.messages import GpsFix

CLOCK_DRIFT_ALLOWANCE = 1e-4
"""How fast the receive-minus-UTC offset may grow (s per s, 100 ppm)."""
_DAY_S = 86400.0


class GnssTiming:
    """Retimes fixes to when they were measured (see the module docstring)."""

    def __init__(self, latency_s: float | None, from_utc: bool) -> None:
        self.latency_s = 0.0 if latency_s is None else latency_s  # None: not configured
        self.from_utc = from_utc
        self.offset_s: float | None = None
        """Receive time minus UTC time of day (s), the smallest seen (with the creep)."""
        self._last_utc_s: float | None = None

    @property
    def active(self) -> bool:
        """False when fixes keep their time stamps (no latency, not from UTC)."""
        return self.from_utc or self.latency_s != 0.0

    def retime(self, fix: GpsFix) -> GpsFix:
        """``fix`` stamped at its measurement time (s, the receiving clock)."""
        if not self.active:
            return fix
        t = fix.timestamp_s
        utc = fix.utc_time_s
        if self.from_utc and math.isfinite(utc) and math.isfinite(t):
            raw = t - utc
            offset = raw
            if self.offset_s is not None and self._last_utc_s is not None:
                # A day's wrap of the UTC time of day.
                raw += _DAY_S * round((self.offset_s - raw) / _DAY_S)
                span = (utc - self._last_utc_s) % _DAY_S
                creep = self.offset_s + CLOCK_DRIFT_ALLOWANCE * span
                offset = raw if abs(raw - creep) > 1.0 else min(raw, creep)  # > 1 s: a reset
            self.offset_s = offset
            self._last_utc_s = utc
            t -= raw - offset  # the link's delay beyond the fastest delivery
        return dataclasses.replace(fix, timestamp_s=t - self.latency_s)
