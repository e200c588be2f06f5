"""Timing of the acceleration and skidpad events on the ground truth, as the rules time them.

Timing lines are crossed by the car's front (the photocells see the nose of the car):

- acceleration: from the start line (the big orange cones the car starts behind) to the
  finish line, 75 m on (FS Rules D5);
- skidpad: every pass through the centre gate, in the direction of travel; the laps between
  passes are told right or left by the side of the gate the car drove on, and the second lap
  of each side is the timed one (FS Rules D4).

Evaluation only: nothing here reaches the stack.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from common.messages import GroundTruth
from simulator.track import Track


@dataclass
class _Line:
    """A timing line: its middle (m), unit vector along it, unit normal in the direction of
    travel, half its length (m) plus a metre."""

    mid: tuple[float, float]
    along: tuple[float, float]
    normal: tuple[float, float]
    half_m: float

    @classmethod
    def from_points(cls, line_xy_m: np.ndarray, behind_xy_m: tuple[float, float]
                    ) -> _Line | None:
        """The line through ``line_xy_m`` (2, 2), its normal pointing away from
        ``behind_xy_m`` (where the car starts); None for a line that is not there."""
        if not np.all(np.isfinite(line_xy_m)):
            return None
        (ax, ay), (bx, by) = np.asarray(line_xy_m, np.float64).tolist()
        length = math.hypot(bx - ax, by - ay)
        if length <= 0.0:
            return None
        ux, uy = (bx - ax) / length, (by - ay) / length
        mx, my = 0.5 * (ax + bx), 0.5 * (ay + by)
        nx, ny = -uy, ux
        if (behind_xy_m[0] - mx) * nx + (behind_xy_m[1] - my) * ny > 0.0:
            nx, ny = -nx, -ny
        return cls((mx, my), (ux, uy), (nx, ny), 0.5 * length + 1.0)

    def ahead_m(self, x_m: float, y_m: float) -> float:
        """Signed distance (m) of a point past the line in the direction of travel."""
        return (x_m - self.mid[0]) * self.normal[0] + (y_m - self.mid[1]) * self.normal[1]

    def beside_m(self, x_m: float, y_m: float) -> float:
        """Signed distance (m) of a point along the line from its middle."""
        return (x_m - self.mid[0]) * self.along[0] + (y_m - self.mid[1]) * self.along[1]

    def right_m(self, x_m: float, y_m: float) -> float:
        """Distance (m) of a point to the right of the line's middle, facing the direction of
        travel."""
        return (x_m - self.mid[0]) * self.normal[1] - (y_m - self.mid[1]) * self.normal[0]


@dataclass
class _Crossings:
    """Forward crossings of one line by a point, their times interpolated (s)."""

    line: _Line
    times_s: list[float] = field(default_factory=list)
    _last: tuple[float, float, float] | None = None

    def update(self, t_s: float, x_m: float, y_m: float) -> bool:
        crossed = False
        if self._last is not None:
            t0, x0, y0 = self._last
            d0, d1 = self.line.ahead_m(x0, y0), self.line.ahead_m(x_m, y_m)
            if d0 < 0.0 <= d1:
                f = d0 / (d0 - d1)
                cx, cy = x0 + f * (x_m - x0), y0 + f * (y_m - y0)
                if abs(self.line.beside_m(cx, cy)) <= self.line.half_m:
                    self.times_s.append(t0 + f * (t_s - t0))
                    crossed = True
        self._last = (t_s, x_m, y_m)
        return crossed


class MissionTimer:
    """Times an acceleration or skidpad run from the true poses (see the module docstring).

    ``kind``: ``acceleration`` or ``skidpad``; ``start_line_xy_m`` / ``finish_line_xy_m``
    (2, 2): the timing lines (m; the skidpad's gate is its start line; the car starts at the
    origin, behind them). ``front_m``: the car's front ahead of its origin (m). Feed every true
    pose to :meth:`observe`; :meth:`result` gives the times.
    """

    @classmethod
    def for_track(cls, track: Track, front_m: float) -> MissionTimer:
        """The timer of a layout of kind ``acceleration`` or ``skidpad``."""
        return cls(track.kind, track.start_line_xy_m, track.finish_line_xy_m, front_m)

    def __init__(self, kind: str, start_line_xy_m: np.ndarray, finish_line_xy_m: np.ndarray,
                 front_m: float) -> None:
        self.kind = kind
        self.front_m = front_m
        start = _Line.from_points(start_line_xy_m, (0.0, 0.0))
        finish = _Line.from_points(finish_line_xy_m, (0.0, 0.0))
        self.start = _Crossings(start) if start is not None else None
        self.finish = _Crossings(finish) if finish is not None and kind == "acceleration" \
            else None
        self._side_sum_m: list[float] = [0.0]
        """Sum of the distance right of the gate's middle over each interval between passes
        (skidpad): its sign tells the circle driven."""

    def observe(self, truth: GroundTruth) -> None:
        """One true pose (the car's origin and yaw at ``truth.timestamp_s``)."""
        fx = truth.x_m + self.front_m * math.cos(truth.yaw_rad)
        fy = truth.y_m + self.front_m * math.sin(truth.yaw_rad)
        t = truth.timestamp_s
        if self.start is not None:
            if self.start.update(t, fx, fy):
                self._side_sum_m.append(0.0)
            self._side_sum_m[-1] += self.start.line.right_m(truth.x_m, truth.y_m)
        if self.finish is not None:
            self.finish.update(t, fx, fy)

    def result(self) -> dict[str, Any]:
        """The event's times (s; None where the car never crossed)."""
        if self.kind == "acceleration":
            t0 = self.start.times_s[0] if self.start is not None and self.start.times_s \
                else None
            t1 = self.finish.times_s[0] if self.finish is not None and self.finish.times_s \
                else None
            return {"start_line_s": _round(t0), "finish_line_s": _round(t1),
                    "time_s": _round(t1 - t0) if t0 is not None and t1 is not None else None}
        passes = self.start.times_s if self.start is not None else []
        sides = ["right" if self._side_sum_m[k] > 0.0 else "left"
                 for k in range(1, len(passes))]
        times = [passes[k] - passes[k - 1] for k in range(1, len(passes))]
        right = [t for t, side in zip(times, sides, strict=True) if side == "right"]
        left = [t for t, side in zip(times, sides, strict=True) if side == "left"]
        right_timed = right[1] if len(right) >= 2 else None
        left_timed = left[1] if len(left) >= 2 else None
        mean = (0.5 * (right_timed + left_timed)
                if right_timed is not None and left_timed is not None else None)
        laps = [{"side": side, "time_s": _round(t)}
                for t, side in zip(times, sides, strict=True)]
        return {"gate_passes_s": [_round(t) for t in passes], "laps": laps,
                "right_timed_lap_s": _round(right_timed), "left_timed_lap_s": _round(left_timed),
                "mean_timed_lap_s": _round(mean)}


def _round(value: float | None, digits: int = 3) -> float | None:
    return None if value is None or not math.isfinite(value) else round(value, digits)
