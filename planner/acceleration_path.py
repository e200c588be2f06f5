"""The acceleration event's path: a straight through the middle of the mapped lane.

The rules' layout (FS Rules D5): a straight lane, 75 m from the start line to the finish line
(both marked by big orange cones), then a run-off lane in which the car must stop. The path is
built from the cones mapped so far: a line is fitted to each side's cones (left of the axis and
right of it, whatever their colour: the lane's cones are blue and yellow, the run-off's orange)
and the path is the middle of the two; with one side only, half a nominal lane width from it.
The start line is the big orange cones nearest ahead of the car, the finish 75 m on (or the big
orange cones mapped there); the car stands ``stop_after_finish_m`` past the finish, nearer when
a cone across the lane (its end) is mapped before that.
"""

from __future__ import annotations

import logging
import math

import numpy as np
from numpy.typing import ArrayLike

from planner.mission_path import (
    FloatArray,
    MissionPath,
    big_cone_mask,
    from_axis_frame,
    lane_end_along_m,
    path_end_m,
    straight_points,
    to_axis_frame,
)

logger = logging.getLogger(__name__)

LANE_SEARCH_M = 4.0
"""Cones farther than this (m) beside the axis are no boundary of the lane."""
BOUNDARY_MIN_M = 1.0
"""Cones nearer than this (m) to the axis stand in the lane: an end, not a boundary."""
AXIS_REACHES_M = (15.0, 30.0, 60.0, math.inf, math.inf)
"""The lane's axis is fitted to the cones up to these distances (m) ahead, in turn."""
GATE_SEARCH_M = 10.0
"""The start line's big orange cones are looked for this far (m) ahead of the car."""
FINISH_SEARCH_M = 5.0
"""Big orange cones within this (m) of the rules' finish mark the finish."""


def _side_line(al: FloatArray) -> tuple[float, float] | None:
    """Least-squares line left = a + b along through a side's cones (N, 2); None below 2
    cones or when they span less than a metre."""
    if len(al) < 2 or float(np.ptp(al[:, 0])) < 1.0:
        return None
    b, a = np.polyfit(al[:, 0], al[:, 1], 1)
    return float(a), float(b)


def lane_axis(al_m: FloatArray, nominal_half_width_m: float,
              reach_m: float = math.inf) -> tuple[float, float] | None:
    """The lane's middle as left = a + b along (m, m/m) from cones (N, 2) given as (along,
    left) of a guess of the axis, up to ``reach_m`` ahead; None without two cones on some
    side."""
    keep = (al_m[:, 0] > -3.0) & (al_m[:, 0] < reach_m) \
        & (np.abs(al_m[:, 1]) < LANE_SEARCH_M) & (np.abs(al_m[:, 1]) > BOUNDARY_MIN_M)
    left = _side_line(al_m[keep & (al_m[:, 1] > 0.0)])
    right = _side_line(al_m[keep & (al_m[:, 1] < 0.0)])
    if left is not None and right is not None:
        return 0.5 * (left[0] + right[0]), 0.5 * (left[1] + right[1])
    if left is not None:
        return left[0] - nominal_half_width_m, left[1]
    if right is not None:
        return right[0] + nominal_half_width_m, right[1]
    return None


def acceleration_path(
    cones_xy_m: ArrayLike,
    colours: ArrayLike,
    sizes: ArrayLike | None,
    start_xy_m: tuple[float, float],
    start_yaw_rad: float,
    *,
    length_m: float = 75.0,
    stop_after_finish_m: float = 20.0,
    lane_width_m: float = 3.0,
    front_m: float = 2.25,
    end_clearance_m: float = 2.0,
    extension_m: float = 1.5,
    step_m: float = 0.5,
) -> MissionPath | None:
    """The path (see the module docstring) from mapped cones ``cones_xy_m`` (N, 2) with their
    colours and sizes (N,) for a car that stood at ``start_xy_m`` heading ``start_yaw_rad``
    (rad) at the go; None when no side of the lane is mapped.

    ``length_m``: start line to finish line (m); ``stop_after_finish_m``: where the car stands
    past the finish (m); ``lane_width_m``: the nominal lane (m, for one side mapped only);
    ``front_m``: the car's front ahead of its origin (m), kept ``end_clearance_m`` short of a
    cone across the lane; the points run ``extension_m`` past the stop, every ``step_m``.
    """
    xy = np.asarray(cones_xy_m, np.float64).reshape(-1, 2)
    origin = np.asarray(start_xy_m, np.float64)
    heading = float(start_yaw_rad)
    # near cones first, then farther about the axis found: the split into sides follows the
    # lane (a lane at an angle to the car crosses the car's own axis further on)
    for reach_m in AXIS_REACHES_M:
        fit = lane_axis(to_axis_frame(xy, origin, heading), 0.5 * lane_width_m, reach_m)
        if fit is None:
            if math.isfinite(reach_m):
                continue
            return None
        a, b = fit
        origin = from_axis_frame(np.array([[0.0, a]]), origin, heading)[0]
        heading += math.atan(b)
    # the car's own position along the axis: the path starts there
    car_along = float(to_axis_frame(np.asarray(start_xy_m, np.float64), origin, heading)[0, 0])
    al = to_axis_frame(xy, origin, heading)
    big = big_cone_mask(colours, sizes) & (np.abs(al[:, 1]) < LANE_SEARCH_M)
    ahead = big & (al[:, 0] > car_along - 1.0) & (al[:, 0] < car_along + GATE_SEARCH_M)
    start_line = float(np.mean(al[ahead, 0])) if ahead.any() else car_along
    finish = start_line + length_m
    near_finish = big & (np.abs(al[:, 0] - finish) < FINISH_SEARCH_M)
    if near_finish.any():
        finish = float(np.mean(al[near_finish, 0]))
    stop = finish + stop_after_finish_m
    lane_end = lane_end_along_m(al, start_line + 1.0, 0.5 * lane_width_m - 0.2)
    if math.isfinite(lane_end):
        stop = min(stop, lane_end - front_m - end_clearance_m)
    stop = max(stop, car_along + 1.0)
    along = straight_points(car_along, path_end_m(stop, lane_end, front_m, extension_m), step_m)
    points = from_axis_frame(np.stack([along, np.zeros_like(along)], axis=1), origin, heading)
    timing = np.array([start_line, finish]) - car_along
    logger.debug("acceleration path: start line %.1f m, finish %.1f m, stop %.1f m ahead",
                 start_line - car_along, finish - car_along, stop - car_along)
    return MissionPath(points, timing, stop - car_along)
