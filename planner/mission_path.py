"""A path known in advance from the rules' geometry and the mapped cones (acceleration, skidpad).

:class:`MissionPath` is what the path builders (:mod:`planner.acceleration_path`,
:mod:`planner.skidpad_path`) hand the planner: an open polyline from where the car stood at the
go, the arc lengths of the timing lines along it, the last of which ends the mission, and where
the car is to stand. The planner fits its baseframe through the points and plans its speed
profile to a stop at ``stop_s_m``. Shared helpers for the builders live here too.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from common.messages import ConeColour, ConeSize

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]


@dataclass(frozen=True, slots=True)
class MissionPath:
    """A mission's whole path, world frame.

    ``points_xy_m`` (K, 2): the path in order of travel, about evenly spaced, from the car's
    position at the go. ``timing_s_m`` (T,): arc lengths (m, along the points) of the timing
    lines in the order they are crossed; the last one is the finish. ``stop_s_m``: where the
    car is to stand (m, along the points); the points run a little beyond it. ``complete``:
    False when the path is only the part seen so far (its stop is the end of the known lane;
    the builder is asked again as the map grows).
    """

    points_xy_m: FloatArray
    timing_s_m: FloatArray
    stop_s_m: float
    complete: bool = True

    @property
    def finish_s_m(self) -> float:
        """Arc length (m) of the finish: the last timing line."""
        return float(self.timing_s_m[-1]) if len(self.timing_s_m) else self.stop_s_m

    @property
    def length_m(self) -> float:
        """Length (m) of the polyline."""
        return float(np.sum(np.hypot(*np.diff(self.points_xy_m, axis=0).T)))


def big_cone_mask(colours: ArrayLike, sizes: ArrayLike | None) -> BoolArray:
    """The cones (N,) that are big orange cones: by colour, or by size when the colour is not
    known (the LiDAR tells a big cone by its height)."""
    col = np.asarray(colours, np.int64).reshape(-1)
    big = col == int(ConeColour.BIG_ORANGE)
    if sizes is not None:
        size = np.asarray(sizes, np.int64).reshape(-1)
        if len(size) == len(col):
            big |= (size == int(ConeSize.LARGE)) & (col == int(ConeColour.UNKNOWN))
    return np.asarray(big, np.bool_)


def to_axis_frame(xy_m: ArrayLike, origin_xy_m: ArrayLike, heading_rad: float) -> FloatArray:
    """Points (N, 2) as (along, left) (m) of a frame at ``origin_xy_m`` heading
    ``heading_rad``."""
    p = np.asarray(xy_m, np.float64).reshape(-1, 2) - np.asarray(origin_xy_m, np.float64)
    c, s = math.cos(heading_rad), math.sin(heading_rad)
    return np.stack([p[:, 0] * c + p[:, 1] * s, -p[:, 0] * s + p[:, 1] * c], axis=1)


def from_axis_frame(al_m: ArrayLike, origin_xy_m: ArrayLike, heading_rad: float) -> FloatArray:
    """(along, left) (N, 2) (m) of the frame at ``origin_xy_m`` heading ``heading_rad`` back
    to world points (N, 2)."""
    a = np.asarray(al_m, np.float64).reshape(-1, 2)
    c, s = math.cos(heading_rad), math.sin(heading_rad)
    o = np.asarray(origin_xy_m, np.float64)
    return np.stack([o[0] + a[:, 0] * c - a[:, 1] * s, o[1] + a[:, 0] * s + a[:, 1] * c], axis=1)


def lane_end_along_m(al_m: FloatArray, after_m: float, half_width_m: float) -> float:
    """The nearest cone standing inside a straight lane (|left| < ``half_width_m``) beyond
    ``after_m`` along it: the end of the lane (m along; inf when none is mapped). ``al_m``
    (N, 2) are cones as (along, left) of the lane's axis."""
    inside = (al_m[:, 0] > after_m) & (np.abs(al_m[:, 1]) < half_width_m)
    return float(al_m[inside, 0].min()) if inside.any() else math.inf


PATH_END_CLEARANCE_M = 0.7
"""The path's last point keeps the car's front this far (m) from a cone across the lane: the
manoeuvres run to the path's end, and their check covers the car's front corners (about
0.5 m ahead of the front) plus the cone clearance."""


def path_end_m(stop_m: float, lane_end_m: float, front_m: float, extension_m: float) -> float:
    """Where the path ends (m along): ``extension_m`` past the stop, short of the lane's end
    (``lane_end_m``, inf when unknown) by the car's front ``front_m`` and
    :data:`PATH_END_CLEARANCE_M`; never before the stop."""
    return max(min(stop_m + extension_m, lane_end_m - front_m - PATH_END_CLEARANCE_M), stop_m)


def straight_points(start_m: float, end_m: float, step_m: float) -> FloatArray:
    """Arc lengths (K,) from ``start_m`` to ``end_m`` about ``step_m`` apart, both ends
    included (at least 2)."""
    n = max(int(math.ceil((end_m - start_m) / step_m)), 1)
    return np.linspace(start_m, end_m, n + 1)
