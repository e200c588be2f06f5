"""Laps on a closed baseframe: the car's progress along it, counted from where it started or,
on an explored track, from the start line (the Path Planner's lap count, which the Controller
stops the car on).

The progress is the arc length driven, unwrapped over the lap's seam; a lap is a whole
frame's length of it past the start line. A racing line swapped in for the centre line keeps
the laps done and the car's place in the lap (:meth:`LapCounter.carry_over`).
"""

from __future__ import annotations

import logging
import math

import numpy as np

from common.messages import ConeColour, MapState
from planner.baseframe import SplineBaseframe

logger = logging.getLogger(__name__)


class LapCounter:
    """The car's progress (m) and laps on a closed frame; ``s_hint_m`` (m) is also where the
    planner projects the car from (its arc length at the last plan; None: search the whole
    frame)."""

    def __init__(self, lap_min_fraction: float, start_line_search_m: float) -> None:
        """``lap_min_fraction``: a start less than this fraction of a lap before the line does
        not count its first crossing; ``start_line_search_m`` (m): the big orange cones this
        near the start make the start line of an explored track."""
        self.lap_min_fraction = lap_min_fraction
        self.start_line_search_m = start_line_search_m
        self.s_hint_m: float | None = None
        self.s_start_m: float | None = None
        """The frame's arc length (m) where the count starts."""
        self.progress_m = 0.0
        """Arc length (m) driven from ``s_start_m``."""
        self.line_offset_m: float | None = None
        """Arc length (m) from the start to the start line on a closed explored track."""
        self.lap = 0

    def reset(self, frame: SplineBaseframe | None, map_state: MapState,
              origin_xy: tuple[float, float] | None, explored_m: float) -> None:
        """Start counting on ``frame`` from the car's pose: on an explored closed track
        (``origin_xy``, where the autonomous run started) from the start line, the
        ``explored_m`` (m) driven while exploring included."""
        self.s_hint_m = None
        self.s_start_m = None
        self.progress_m = 0.0
        self.lap = 0
        pose = map_state.pose
        if frame is not None and math.isfinite(pose.x_m) and math.isfinite(pose.y_m):
            s, _ = frame.project(pose.x_m, pose.y_m)
            self.s_hint_m = s
            self.s_start_m = s
            if origin_xy is not None and frame.closed:
                self._count_from_origin(frame, map_state, s, origin_xy, explored_m)

    def _count_from_origin(self, frame: SplineBaseframe, map_state: MapState, s_car_m: float,
                           origin_xy: tuple[float, float], explored_m: float) -> None:
        """Laps of an explored track count from the start line (the big orange cones nearest
        the start, else the start itself), the explored lap included."""
        length = frame.length_m
        s_origin, _ = frame.project(*origin_xy)
        cones = map_state.cones
        big = cones.xy_m[cones.colour == int(ConeColour.BIG_ORANGE)] if len(cones) else cones.xy_m
        if len(big):
            near = np.hypot(big[:, 0] - origin_xy[0], big[:, 1] - origin_xy[1])
            big = big[near < self.start_line_search_m]
        s_line = frame.project(*big.mean(axis=0))[0] if len(big) else s_origin
        self.line_offset_m = (s_line - s_origin) % length
        self.s_start_m = s_origin
        self.progress_m = (s_car_m - s_origin) % length
        # the loop may close only after the car has passed the start again: whole laps from
        # the distance driven while exploring
        self.progress_m += length * max(round((explored_m - self.progress_m) / length), 0)
        logger.info("laps count from the start line %.1f m past the start; %.1f m driven",
                    self.line_offset_m, self.progress_m)

    def laps_done(self, frame: SplineBaseframe | None) -> float | None:
        """Laps done on the closed ``frame``, with the fraction of the lap the car is in (None
        before progress is counted): what :meth:`update` floors."""
        if frame is None or not frame.closed or self.s_start_m is None:
            return None
        length = frame.length_m
        if self.line_offset_m is not None:
            return (self.progress_m - self.line_offset_m) / length
        done = (self.s_start_m + self.progress_m) / length
        if length - self.s_start_m < self.lap_min_fraction * length:
            done -= 1.0  # started just before the line: its first crossing is no lap
        return done

    def update(self, frame: SplineBaseframe | None, s_m: float) -> None:
        """The car is at arc length ``s_m`` (m) of ``frame``: its progress and laps (on a
        closed frame; an open one counts nothing)."""
        if frame is None or not frame.closed:
            return
        if self.s_start_m is None:
            self.s_start_m = s_m
            self.s_hint_m = s_m
            return
        assert self.s_hint_m is not None
        self.progress_m += math.remainder(s_m - self.s_hint_m, frame.length_m)
        done = self.laps_done(frame)
        assert done is not None
        self.lap = max(self.lap, math.floor(done))

    def carry_over(self, frame: SplineBaseframe, laps_done: float) -> None:
        """After :meth:`reset` on a new closed ``frame`` (a racing line for the centre line):
        the same place in the lap, the nearest whole number of laps to ``laps_done`` (the old
        frame's :meth:`laps_done`; its start may lie a little before or after the new one's)."""
        length = frame.length_m
        if self.line_offset_m is not None:
            fraction = ((self.progress_m - self.line_offset_m) / length) % 1.0
            self.progress_m = self.line_offset_m + (round(laps_done - fraction)
                                                    + fraction) * length
        elif self.s_hint_m is not None:
            fraction = (self.s_hint_m % length) / length
            self.s_start_m = 0.0
            self.progress_m = (round(laps_done - fraction) + fraction) * length
