"""The lane's boundaries near the car, as walls a manoeuvre may not leave through (issue 45).

The manoeuvres are checked against the cones, not against the boundary between them: on a 3 m
lane a manoeuvre 2.5 m to one side runs out between two of the lane's cones (3.9 m apart) with
room to spare from each. Only a plan with nothing else left takes one (``hard:hairpins``
autocross seed 6: a cone the camera alone had seen stood in the middle of the lane 15 m ahead
for 0.6 s, and the car went out to its left, then hit the start gate's cones turning back).

Here each side's boundary near the car is the line through its cones in order along the path:
a blue cone left of the path and a yellow one right of it (the colour and the side agree; an
orange cone, of the start and finish gates, on the side it lies), each cone joined to the
first one of the same side further along that continues its row: at most :data:`MAX_GAP_M` on
and the line between them roughly along the path (a cone of the wrong colour, or of another
stretch of track, makes no wall across the lane, nor a gap in the lane's own). Without colours
there are no walls. A manoeuvre that leaves the lane through one (from its inside to its
outside) is refused; one that comes back in is not (the car may stand over a boundary
already).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from common.conventions import wrap_angles
from common.messages import ConeColour
from planner.baseframe import SplineBaseframe

FloatArray = NDArray[np.float64]

REACH_M = 12.0
"""Walls are made of the cones this near the car (m): the manoeuvres that leave the lane do so
near the car, and further on the path through the cones is less sure."""
MAX_GAP_M = 6.0
"""Two cones of a side further apart than this (m) make no wall (the rules space a side's cones
at most 5 m apart on straights)."""
MAX_ANGLE_RAD = 0.6
"""A wall is at most this far from the path's direction (rad) at its middle."""


def boundary_walls(frame: SplineBaseframe, cones_xy_m: FloatArray, colours: NDArray[np.int64],
                   car_xy_m: tuple[float, float], reach_m: float = REACH_M) -> FloatArray:
    """Wall segments (W, 2, 2) (m, world frame), each oriented so that the lane is on its
    right: from the cones (N, 2) of colour (N,) within ``reach_m`` of the car along ``frame``."""
    xy = np.asarray(cones_xy_m, np.float64).reshape(-1, 2)
    col = np.asarray(colours, np.int64).reshape(-1)
    near = np.hypot(xy[:, 0] - car_xy_m[0], xy[:, 1] - car_xy_m[1]) <= reach_m
    xy, col = xy[near], col[near]
    if len(xy) < 2:
        return np.zeros((0, 2, 2))
    s, d = frame.project_many(xy)
    walls = []
    orange = (col == int(ConeColour.ORANGE)) | (col == int(ConeColour.BIG_ORANGE))
    for colour, sign in ((int(ConeColour.BLUE), 1.0), (int(ConeColour.YELLOW), -1.0)):
        side = ((col == colour) | orange) & (np.sign(d) == sign)
        order = np.argsort(s[side], kind="stable")
        pts, ss = xy[side][order], s[side][order]
        if len(pts) < 2:
            continue
        a, b = _row_links(frame, pts, ss)
        # the lane on the right: a left wall runs with the path, a right wall against it
        walls.append(np.stack([a, b], axis=1) if sign > 0 else np.stack([b, a], axis=1))
    return np.concatenate(walls) if walls else np.zeros((0, 2, 2))


def _row_links(frame: SplineBaseframe, pts: FloatArray, s_m: FloatArray
               ) -> tuple[FloatArray, FloatArray]:
    """Each cone of one side (K, 2), in order along the path (``s_m``, (K,)), joined to the
    next one on that continues its row: the first further along at most :data:`MAX_GAP_M` on
    and at most :data:`MAX_ANGLE_RAD` from the path's direction. A cone of another stretch
    of track on the same side (``hard:hairpins``: the next lane's row 3 m across the infield)
    comes between two of the lane's cones in that order; joined to it, the row had no wall
    there, and a manoeuvre left the lane through the gap. Returns the walls' ends (W, 2) x 2."""
    step = pts[None, :, :] - pts[:, None, :]  # (K, K, 2): from cone i to cone j
    length = np.hypot(step[..., 0], step[..., 1])
    later = np.arange(len(pts))[None, :] > np.arange(len(pts))[:, None]
    ok = later & (length <= MAX_GAP_M) & (length > 1e-6)
    i, j = np.nonzero(ok)  # the frame is sampled only between cones near enough
    _, _, heading, _ = frame.sample(0.5 * (s_m[i] + s_m[j]))
    ok[i, j] = np.abs(wrap_angles(np.arctan2(step[i, j, 1], step[i, j, 0]) - heading)
                      ) <= MAX_ANGLE_RAD
    first = np.argmax(ok, axis=1)  # the nearest along the path of those that qualify
    has = ok[np.arange(len(pts)), first]
    return pts[has], pts[first[has]]


def leaves_through(paths_xy_m: FloatArray, walls: FloatArray) -> NDArray[np.bool_]:
    """Whether each path (C, K, 2) crosses a wall (W, 2, 2) from its right (the lane) to its
    left (C,)."""
    paths = np.asarray(paths_xy_m, np.float64)
    out = np.zeros(paths.shape[0], bool)
    if len(walls) == 0 or paths.shape[1] < 2:
        return out
    p, q = paths[:, :-1, None, :], paths[:, 1:, None, :]  # (C, K-1, 1, 2)
    a, b = walls[None, None, :, 0, :], walls[None, None, :, 1, :]  # (1, 1, W, 2)

    def cross(o: FloatArray, u: FloatArray, v: FloatArray) -> FloatArray:
        return np.asarray((u[..., 0] - o[..., 0]) * (v[..., 1] - o[..., 1])
                          - (u[..., 1] - o[..., 1]) * (v[..., 0] - o[..., 0]), np.float64)

    side_p, side_q = cross(a, b, p), cross(a, b, q)  # < 0: right of the wall, the lane
    leaving = (side_p < 0.0) & (side_q > 0.0)
    within = cross(p, q, a) * cross(p, q, b) <= 0.0  # the wall's ends on either side
    out = np.any(leaving & within, axis=(1, 2))
    return np.asarray(out, bool)
