"""How near the car came to a cone: the least gap between its outline and any cone's base.

A run is clean when no cone was touched; this says by how much. EPFL's Vaudoise autocross
was clean on every seed while the car passed its hairpin's exit cone by 0.00-0.03 m: a hit in
waiting that the cone count did not show. The gap is measured on the logged ground-truth poses
(one per control tick), so between two samples the car may have come nearer by up to the
distance it drove in a tick times the sine of its angle to the cone.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial import cKDTree

from common.car import CarConfig
from simulator.track import Track

FloatArray = NDArray[np.float64]

REACH_M = 3.0
"""Cones farther than this (m) from the outline are not looked at (the gap is then reported
as at least this)."""


@dataclass(frozen=True)
class Clearance:
    """The least gap over a trajectory."""

    gap_m: float
    """Outline to the cone's base (m); negative: they overlap (a cone touched)."""
    cone: int
    """The cone's index (-1: none within ``REACH_M``)."""
    sample: int
    """The index of the pose where it was least (-1: none within ``REACH_M``)."""


def outline_gaps_m(poses: ArrayLike, cones_xy_m: ArrayLike, rear_m: float, front_m: float,
                   half_width_m: float) -> FloatArray:
    """The gap (m) between each pose's outline and each cone's centre, pairwise.

    ``poses`` (P, 3): x, y (m), yaw (rad) of the reference point; ``cones_xy_m`` (P, 2), the
    cone paired with each pose. The outline is the rectangle from ``rear_m`` to ``front_m``
    along the heading (m, ``rear_m`` negative behind the reference point) and
    ``half_width_m`` to either side; a centre inside it reads 0.
    """
    p = np.asarray(poses, np.float64).reshape(-1, 3)
    c = np.asarray(cones_xy_m, np.float64).reshape(-1, 2)
    dx, dy = c[:, 0] - p[:, 0], c[:, 1] - p[:, 1]
    cos_y, sin_y = np.cos(p[:, 2]), np.sin(p[:, 2])
    along = dx * cos_y + dy * sin_y
    across = -dx * sin_y + dy * cos_y
    out_along = np.maximum(np.maximum(rear_m - along, along - front_m), 0.0)
    out_across = np.maximum(np.abs(across) - half_width_m, 0.0)
    return np.asarray(np.hypot(out_along, out_across), np.float64)


def least_clearance(poses: ArrayLike, cones_xy_m: ArrayLike, cone_radius_m: ArrayLike,
                    rear_m: float, front_m: float, half_width_m: float) -> Clearance:
    """The least gap between the car's outline at ``poses`` (T, 3: x, y, yaw) and the base
    of any cone at ``cones_xy_m`` (N, 2) of radius ``cone_radius_m`` (N,) (m); the outline
    as :func:`outline_gaps_m`. Non-finite poses are skipped."""
    p = np.asarray(poses, np.float64).reshape(-1, 3)
    cones = np.asarray(cones_xy_m, np.float64).reshape(-1, 2)
    radius = np.broadcast_to(np.asarray(cone_radius_m, np.float64), (len(cones),))
    keep = np.flatnonzero(np.all(np.isfinite(p), axis=1))
    if len(keep) == 0 or len(cones) == 0:
        return Clearance(float("inf"), -1, -1)
    # the outline's middle and the farthest its corners reach from it
    middle_m = 0.5 * (rear_m + front_m)
    half_diagonal_m = float(np.hypot(0.5 * (front_m - rear_m), half_width_m))
    centres = p[keep, :2] + middle_m * np.column_stack([np.cos(p[keep, 2]), np.sin(p[keep, 2])])
    near = cKDTree(cones).query_ball_point(
        centres, half_diagonal_m + REACH_M + float(radius.max()))
    counts = np.fromiter((len(n) for n in near), np.int64, len(near))
    if counts.sum() == 0:
        return Clearance(float("inf"), -1, -1)
    pose_of = np.repeat(keep, counts)
    cone_of = np.fromiter((i for n in near for i in n), np.int64, int(counts.sum()))
    gaps = outline_gaps_m(p[pose_of], cones[cone_of], rear_m, front_m, half_width_m)
    gaps = gaps - radius[cone_of]
    k = int(np.argmin(gaps))
    if gaps[k] > REACH_M:
        return Clearance(float("inf"), -1, -1)
    return Clearance(float(gaps[k]), int(cone_of[k]), int(pose_of[k]))


def run_clearance(t_s: ArrayLike, truth: ArrayLike, track: Track, car: CarConfig
                  ) -> dict[str, Any]:
    """A run's least clearance for its summary: ``gap_m`` (m, rounded to mm; None when no
    cone came within ``REACH_M``), the ``cone`` and its ``xy_m``, and ``time_s``; from the
    logged times ``t_s`` (T,) and ground-truth rows ``truth`` (T, >= 3: x, y, yaw, ...) of
    ``car`` (its outline as the simulated vehicle's) on ``track``."""
    times = np.asarray(t_s, np.float64).reshape(-1)
    rows = np.asarray(truth, np.float64)
    n = min(len(times), len(rows))
    poses = rows.reshape(len(rows), -1)[:n, :3] if n else np.zeros((0, 3))
    least = least_clearance(poses, track.cones_xy_m, track.cone_radius_m,
                            -car.rear_overhang_m, car.length_m - car.rear_overhang_m,
                            0.5 * car.width_m)
    if least.cone < 0:
        return {"gap_m": None, "cone": None, "xy_m": None, "time_s": None}
    return {"gap_m": round(least.gap_m, 3), "cone": least.cone,
            "xy_m": [round(float(v), 3) for v in track.cones_xy_m[least.cone]],
            "time_s": round(float(times[least.sample]), 3)}
