"""Which points lie near which: the pairs of two small point sets within a radius.

For the few tens to hundreds of points the mapper and the planner compare on every frame (a
camera frame's cones against the landmarks, a path's points against the map's cones), a
distance matrix over the points inside the first set's bounding box costs less than building
and querying a KD-tree (scipy's ``cKDTree``, kept for the large sets)."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

IntArray = NDArray[np.int64]


def pairs_within(points_xy_m: ArrayLike, others_xy_m: ArrayLike, radius_m: float
                 ) -> tuple[IntArray, IntArray]:
    """Index pairs (i, j), i into ``points_xy_m`` (N, 2) and j into ``others_xy_m`` (M, 2)
    (both m), whose distance is at most ``radius_m`` (m); ordered by i, then j."""
    a = np.asarray(points_xy_m, np.float64).reshape(-1, 2)
    b = np.asarray(others_xy_m, np.float64).reshape(-1, 2)
    none = np.zeros(0, np.int64)
    if len(a) == 0 or len(b) == 0:
        return none, none
    lo, hi = a.min(axis=0) - radius_m, a.max(axis=0) + radius_m
    inside = np.flatnonzero((b[:, 0] >= lo[0]) & (b[:, 0] <= hi[0])
                            & (b[:, 1] >= lo[1]) & (b[:, 1] <= hi[1]))
    if len(inside) == 0:
        return none, none
    d2 = ((a[:, None, :] - b[None, inside, :]) ** 2).sum(axis=2)
    i, k = np.nonzero(d2 <= radius_m * radius_m)
    return i.astype(np.int64), inside[k].astype(np.int64)


def near_any(points_xy_m: ArrayLike, others_xy_m: ArrayLike, radius_m: float
             ) -> NDArray[np.bool_]:
    """Which of ``points_xy_m`` (N, 2) have one of ``others_xy_m`` (M, 2) within ``radius_m``
    (all m): (N,)."""
    i, _ = pairs_within(points_xy_m, others_xy_m, radius_m)
    near = np.zeros(len(np.asarray(points_xy_m).reshape(-1, 2)), bool)
    near[i] = True
    return near
