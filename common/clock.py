"""Clocks: the only place the stack learns what time it is.

Main owns one Clock and hands it to whoever needs the time. Logic never calls ``time.time()``:
in simulation and replay the clock is advanced by whoever drives time, which is what makes a
replay produce the same outputs, bit for bit, at any rate.
"""

from __future__ import annotations

import threading
import time
from typing import Protocol


class Clock(Protocol):
    """A source of time (s)."""

    def now_s(self) -> float:
        """Current time on this clock (s)."""
        ...

    def sleep_until(self, t_s: float) -> None:
        """Block until the clock reads at least ``t_s`` (returns at once if it already does)."""
        ...


class RealClock:
    """Wall time from a monotonic source, in seconds since the clock was made (plus ``start_s``)."""

    def __init__(self, start_s: float = 0.0) -> None:
        self._t0 = time.monotonic() - start_s

    def now_s(self) -> float:
        return time.monotonic() - self._t0

    def sleep_until(self, t_s: float) -> None:
        delay = t_s - self.now_s()
        if delay > 0.0:
            time.sleep(delay)


class SimClock:
    """A clock that moves only when told to (simulation and replay).

    ``advance``/``set`` move it forward; it never goes backwards. ``sleep_until`` waits on
    another thread advancing it (with an optional wall-clock ``timeout_s`` as a guard).
    """

    def __init__(self, start_s: float = 0.0) -> None:
        self._t_s = float(start_s)
        self._cond = threading.Condition()

    def now_s(self) -> float:
        return self._t_s

    def set(self, t_s: float) -> None:
        """Move the clock to ``t_s`` (s); a time before now raises ``ValueError``."""
        with self._cond:
            if t_s < self._t_s:
                raise ValueError(f"SimClock cannot go back from {self._t_s} to {t_s}")
            self._t_s = float(t_s)
            self._cond.notify_all()

    def advance(self, dt_s: float) -> float:
        """Move the clock forward by ``dt_s`` >= 0 (s); returns the new time."""
        if dt_s < 0.0:
            raise ValueError(f"SimClock cannot advance by a negative step {dt_s}")
        self.set(self._t_s + dt_s)
        return self._t_s

    def sleep_until(self, t_s: float, timeout_s: float | None = None) -> None:
        with self._cond:
            self._cond.wait_for(lambda: self._t_s >= t_s, timeout=timeout_s)
