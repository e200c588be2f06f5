"""The car's progress while it explores a track it has not mapped yet: the distance driven,
the laps counted where it crosses the start line (while no loop is mapped), the way it came
(whose gates the exploration path never takes back the other way), and from these whether a
loop found in the cones may be the track.
"""

from __future__ import annotations

import logging
import math

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from common.messages import ConeColour, MapState
from common.polyline import nearest_on_polyline, polyline_length, resample
from planner.config import PlannerConfig

logger = logging.getLogger(__name__)

FloatArray = NDArray[np.float64]

MIN_START_LINE_M = 2.0
"""Big orange cones spread less than this (m) stand on one side of the track only."""
TRACE_STEP_M = 0.5
"""Spacing of the driven trace kept while exploring (m)."""
DRIVEN_NEAR_M, DRIVEN_BEHIND_M = 3.0, 40.0
"""The stretch of the driven trace (m behind the car) whose gates are behind it."""


def _crossing(last: FloatArray, here: FloatArray, point: FloatArray, along_xy: FloatArray,
              half_m: float) -> bool:
    """Whether the step from ``last`` to ``here`` (m) crosses the line through ``point`` along
    ``along_xy`` towards its left, within ``half_m`` (m) of ``point``."""
    normal = np.array([-along_xy[1], along_xy[0]])
    before, after = float((last - point) @ normal), float((here - point) @ normal)
    if not before < 0.0 <= after:
        return False
    cross = last + (here - last) * (before / (before - after))
    return abs(float((cross - point) @ along_xy)) <= half_m


class ExploredLap:
    """Progress from the start pose ``origin_xy`` (m) heading ``origin_yaw_rad``, fed the car's
    position at each plan (:meth:`update`)."""

    def __init__(self, origin_xy: tuple[float, float], origin_yaw_rad: float,
                 config: PlannerConfig) -> None:
        self.config = config
        self._origin_xy = origin_xy
        self._origin_yaw_rad = origin_yaw_rad
        self.laps = 0
        """Laps counted at the start line."""
        self.explored_m = 0.0
        """Distance (m) driven while exploring, from the poses the planner saw."""
        self._last_crossing_m = 0.0
        """``explored_m`` at the last crossing of the start line."""
        self._last_xy: tuple[float, float] | None = None
        self._trace: list[tuple[float, float]] = []
        """Where the car was while exploring, ``TRACE_STEP_M`` apart (world frame, m)."""
        self._last_line: tuple[FloatArray, FloatArray, float] | None = None
        """The start line (point, direction, half-length) at the last call, when across."""
        self._point_ahead_m: float | None = None
        """How far ahead of the car (m) the start line's point was, when the car passes it
        abreast (the big cones of one side only)."""

    def update(self, x_m: float, y_m: float, map_state: MapState) -> None:
        """Distance driven while exploring, and laps counted where the car crosses the start
        line while no loop is mapped (with no cone colours the big orange cones and the loop's
        closure may never come, and the lap is still done).

        The start line is the line through the big orange cones mapped near the start, across
        the track as they stand (a layout may start the car a quarter of a lap before them, its
        line not square to the car's start heading), crossed within a metre of their ends; with
        those of one side only (the other not seen in colour), the car passes abreast of them
        within a track width; with none, the line across the start heading within a track
        width of the start. A crossing is a lap only ``lap_min_m`` after the last (or the
        start): a car that starts behind the line starts the clock there."""
        point, along_xy, half_m = self.start_line(map_state)
        here = np.array([x_m, y_m])
        if self._last_xy is not None:
            last = np.asarray(self._last_xy)
            step_m = float(np.hypot(*(here - last)))
            self.explored_m += step_m
            crossed, off_m = False, math.inf
            if along_xy is None:
                # the car passes abreast of the point: it was ahead and is now beside or behind
                # (the sign kept from the last call: a plane that turns with the car in a bend
                # may jump over the car between two calls)
                if step_m > 1e-6:
                    forward = (here - last) / step_m
                    ahead_m = float((point - here) @ forward)
                    was_m = self._point_ahead_m
                    crossed = was_m is not None and was_m > 0.0 >= ahead_m
                    off_m = abs(float((here - point) @ np.array([forward[1], -forward[0]])))
                    self._point_ahead_m = ahead_m
            else:
                self._point_ahead_m = None
                crossed = _crossing(last, here, point, along_xy, half_m)
                prev = self._last_line
                if not crossed and prev is not None:
                    # the line moved under the car as it crossed (the map froze: its big
                    # cones merged, EUFS Jellybean seed 9 missed its lap and drove another):
                    # the line it was approaching counts
                    crossed = _crossing(last, here, *prev)
                off_m = 0.0
            if crossed and off_m <= half_m:
                if self.explored_m - self._last_crossing_m >= self.config.lap_min_m:
                    self.laps += 1
                    logger.info("exploring: start line crossed after %.0f m: lap %d",
                                self.explored_m, self.laps)
                else:
                    logger.debug("exploring: start line crossed after %.0f m, %.0f m after the "
                                 "last: not a lap", self.explored_m,
                                 self.explored_m - self._last_crossing_m)
                self._last_crossing_m = self.explored_m
        self._last_xy = (x_m, y_m)
        self._last_line = (point, along_xy, half_m) if along_xy is not None else None
        if not self._trace or math.hypot(x_m - self._trace[-1][0],
                                         y_m - self._trace[-1][1]) >= TRACE_STEP_M:
            self._trace.append((x_m, y_m))

    def start_line(self, map_state: MapState) -> tuple[FloatArray, FloatArray | None, float]:
        """The start line while exploring: a point on it, its unit direction (the car crosses
        it towards the left of that direction; None: square to the car's own direction, the
        big cones of one side only) and the half-length (m) about the point within which a
        crossing counts."""
        origin = np.asarray(self._origin_xy, np.float64)
        heading = np.array([math.cos(self._origin_yaw_rad), math.sin(self._origin_yaw_rad)])
        cones = map_state.cones
        if len(cones):
            big = cones.xy_m[cones.colour == int(ConeColour.BIG_ORANGE)]
            big = big[np.hypot(*(big - origin).T) < self.config.start_line_search_m]
            if len(big):
                centre = big.mean(axis=0)
                # the line's direction: the big cones' principal axis when they stand on both
                # sides (further apart than a track is narrow), else across the start heading
                _, _, vt = np.linalg.svd(big - centre)
                along = vt[0]
                extent = np.abs((big - centre) @ along)
                if len(big) < 2 or 2.0 * float(extent.max()) < MIN_START_LINE_M:
                    return centre, None, self.config.nominal_track_width_m
                forward = np.array([-along[1], along[0]])  # crossed towards its left
                if float(forward @ (centre - origin)) + float(forward @ heading) < 0.0:
                    along = -along
                return centre, along, float(extent.max()) + 1.0
        along = np.array([heading[1], -heading[0]])
        return origin, along, self.config.nominal_track_width_m

    def driven_behind(self) -> FloatArray | None:
        """The way the car came while exploring (M, 2): from ``DRIVEN_BEHIND_M`` back to
        ``DRIVEN_NEAR_M`` behind it (the gate it is in and the one just behind stay free);
        None when it has driven less."""
        if len(self._trace) < 2:
            return None
        trace = np.asarray(self._trace[-(int(DRIVEN_BEHIND_M / TRACE_STEP_M) + 2):], np.float64)
        back = np.concatenate([np.cumsum(np.hypot(*np.diff(trace[::-1], axis=0).T))[::-1],
                               [0.0]])
        keep = (back >= DRIVEN_NEAR_M) & (back <= DRIVEN_BEHIND_M)
        return trace[keep] if np.count_nonzero(keep) >= 2 else None

    def loop_off_driven_m(self, points_xy_m: FloatArray) -> float:
        """How far (m) a loop found in the cones (``points_xy_m`` (K, 2), ordered from the car)
        strays from the way the car drove, at most: its points beyond the undriven stretch
        ahead of the car (``loop_unseen_max_m``) to the nearest point of the driven trace;
        0 with fewer than two trace points.

        The car explored through the gates' middles, so the track's loop runs within a metre
        or so of it; a loop that strays further went through gates of another stretch (cones
        of unknown colour, after a camera outage, paired across the inside of a bend: FSG, a
        3 s outage at 12 m/s, the loop ran 3 m outside the inner boundary of a bend and its
        racing line passed 0.1 m from a cone)."""
        trace = np.asarray(self._trace, np.float64)
        pts = np.asarray(points_xy_m, np.float64).reshape(-1, 2)
        if len(trace) < 2 or len(pts) < 2:
            return 0.0
        pts = resample(pts, TRACE_STEP_M, True)  # the chords between gates too
        along = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(pts, axis=0).T))])
        driven = pts[along > self.config.loop_unseen_max_m]
        if len(driven) == 0:
            return 0.0
        # The nearest trace point, then the trace's two segments beside it: the trace grows
        # with every lap explored, and every segment against every point would too.
        nearest = cKDTree(trace).query(driven)[1]
        best = np.full(len(driven), np.inf)
        for first in (nearest - 1, nearest):
            i = np.clip(first, 0, len(trace) - 2)
            a, ab = trace[i], trace[i + 1] - trace[i]
            t = np.clip(((driven - a) * ab).sum(axis=1) / np.maximum((ab * ab).sum(axis=1),
                                                                    1e-12), 0.0, 1.0)
            best = np.minimum(best, np.hypot(*(a + t[:, None] * ab - driven).T))
        return float(best.max())

    def loop_search_pointless(self, x_m: float, y_m: float, min_loop_m: float,
                              mission: str) -> bool:
        """Whether :meth:`loop_refusal` would refuse any loop the cones could make now, the car
        at (``x_m``, ``y_m``), so the search for one (a quarter of the local planner's call) can
        be left out: in autocross; before the car has driven ``min_loop_m - loop_unseen_max_m``
        (a loop is at least ``min_loop_m`` long); and in the first lap while the car is further
        from the start than ``loop_unseen_max_m`` plus the start's ``loop_through_start_m`` and
        a tenth of the distance driven. The loop is ordered from the car and passes the start,
        so the track ahead of the car to the start is at least that straight distance; the car
        has driven the rest of the loop (give or take a tenth: its line is not the middle), and
        an accepted loop leaves at most ``loop_unseen_max_m`` of it unseen."""
        if mission == "autocross":
            return True
        c = self.config
        if self.explored_m < min_loop_m - c.loop_unseen_max_m:
            return True
        if self.laps >= 1:
            return False
        reach_m = c.loop_unseen_max_m + c.loop_through_start_m + 0.1 * self.explored_m
        return math.hypot(x_m - self._origin_xy[0], y_m - self._origin_xy[1]) > reach_m

    def loop_refusal(self, points_xy_m: FloatArray, mission: str) -> str:
        """Why a loop found in the cones (``points_xy_m`` (K, 2), closed) is not the track
        ('' when it is): it misses the start (one lobe of a figure-like layout closed through
        another stretch's cones); the car has not driven all but ``loop_unseen_max_m`` of it (a
        loop through cones seen across a narrow waist cuts a bend not mapped yet); the
        mission is an autocross (one lap: nothing to race on the closed map, and building its
        racing line takes the planner a second that drive's plans have not got; the lap ends
        at the line); or it strays more than ``loop_off_driven_max_m`` from the way the car drove
        (:meth:`loop_off_driven_m`: gates paired across the inside of a bend)."""
        c = self.config
        to_start_m = nearest_on_polyline(np.asarray([self._origin_xy]), points_xy_m, True)[0][0]
        if to_start_m > c.loop_through_start_m:
            return "loop_misses_start"
        if self.explored_m < polyline_length(points_xy_m, True) - c.loop_unseen_max_m:
            return "loop_ahead_unseen"
        if mission == "autocross":
            return "loop_in_autocross"
        off_m = self.loop_off_driven_m(points_xy_m)
        logger.debug("a loop in the cones: %.2f m off the way driven at most", off_m)
        if off_m > c.loop_off_driven_max_m:
            return "loop_off_driven"
        return ""

