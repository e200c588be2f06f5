"""Progress of long work (``sim``, ``replay``, ``render``, benchmarks): a one-line bar on a
terminal (tqdm, on stderr), else a plain log line on the ``progress`` logger every
:data:`LINE_PERIOD_S` of wall time, so that CI logs and pipes see the run move.

The caller says how far it is (``done`` of ``total`` units) and what to show beside it (a short
status such as the simulated time, the real-time factor and the last lap time).
"""

from __future__ import annotations

import logging
import sys
import time
from collections.abc import Callable
from typing import Any

progress_log = logging.getLogger("progress")

LINE_PERIOD_S = 5.0
"""Wall time (s) between two plain progress lines when not on a terminal."""

BAR_REFRESH_S = 0.25
"""Least wall time (s) between two redraws of the bar's status."""


class Progress:
    """``name``: what runs (``sim``, ``replay``); ``total``: units to do (None: unknown);
    ``unit``: their name; ``bar``: draw a bar (on a terminal) instead of plain lines.

    The wall clock is read through ``time.perf_counter`` at each call (tests replace it)."""

    def __init__(self, name: str, total: int | None, unit: str, bar: bool,
                 period_s: float = LINE_PERIOD_S) -> None:
        self.name = name
        self.total = total
        self.unit = unit
        self.period_s = period_s
        self.done = 0
        self._bar: Any = None
        if bar:
            from tqdm import tqdm

            self._bar = tqdm(total=total, desc=name, unit=unit, leave=False,
                             dynamic_ncols=True)
        self._wall0 = time.perf_counter()
        self._next_line_s = period_s
        self._next_bar_s = 0.0
        self.wall_s = 0.0
        """Wall time (s) from the start to the last :meth:`update`."""

    def update(self, done: int, status: str | Callable[[], str] = "") -> None:
        """``done`` units so far (absolute, not a step); ``status``: the text beside them, or a
        function making it (called only when it is shown: cheap to call every tick)."""
        wall = self.wall_s = time.perf_counter() - self._wall0
        if self._bar is not None:
            if done != self.done:
                self._bar.update(done - self.done)
            if wall >= self._next_bar_s:
                self._next_bar_s = wall + BAR_REFRESH_S
                self._bar.set_postfix_str(status() if callable(status) else status,
                                          refresh=True)
        elif wall >= self._next_line_s:
            self._next_line_s = wall + self.period_s
            text = status() if callable(status) else status
            of = f" of {self.total}" if self.total is not None else ""
            progress_log.info("%s: %s %d%s%s", self.name, self.unit, done, of,
                              f", {text}" if text else "")
        self.done = done

    def write(self, line: str) -> None:
        """Print ``line`` on stdout above the bar (a table row of a benchmark)."""
        if self._bar is not None:
            self._bar.write(line, file=sys.stdout)
        else:
            sys.stdout.write(line + "\n")
            sys.stdout.flush()

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()
            self._bar = None


def realtime_status(sim_time_s: float, wall_s: float) -> str:
    """``t=123 s, 1.9x real time``: simulated (or recording) time and the real-time factor."""
    return f"t={sim_time_s:.0f} s, {sim_time_s / max(wall_s, 1e-9):.1f}x real time"
