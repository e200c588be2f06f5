"""The track as the map knows it: a centreline with the free width to each side.

From the mapped cones and a guide that goes once along the track (the exploration lap's
waypoints, or the cones' midpoints): every cone is projected onto the guide; blue cones are the
left boundary, yellow the right, a cone of unknown colour (or orange) goes to the side it lies
on. Each side's cones, joined in order along the guide, make the boundary polyline (so the chord
between two cones counts, not an arc through them); the centreline is the middle between the
boundaries, refined a few times.

Room is measured as a disc would feel it: the distance from a point to the nearest point of a
boundary polyline, at offsets along the centreline's normals (:meth:`TrackModel.free_interval`),
so that the inside of a tight bend, where a normal meets the boundary far from where the cones
are nearest, is not overstated.

A side with too few cones is taken as the other side moved across by the nominal track width.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial import cKDTree

from common.errors import TrackError
from common.messages import ConeColour
from planner.baseframe import SplineBaseframe

logger = logging.getLogger(__name__)

FloatArray = NDArray[np.float64]

BOUNDARY_STEP_M = 0.2
"""Spacing (m) of the points a boundary polyline is sampled at."""
OFFSET_STEP_M = 0.05
OFFSET_RANGE_M = 5.0
"""Offsets along the normals (m) at which the room to the boundaries is measured."""


@dataclass(frozen=True, slots=True)
class TrackModel:
    """A track: centreline samples (N, 2) evenly ``step_m`` apart (a loop has no duplicated end
    sample), the room (m) from each sample to the left and right boundary polylines (N,) (cone
    centres; the nearest distance), the boundary cones in order ((L, 2), (R, 2)) and the
    boundaries sampled every :data:`BOUNDARY_STEP_M` ((P, 2), (Q, 2))."""

    centre_xy_m: FloatArray
    left_width_m: FloatArray
    right_width_m: FloatArray
    closed: bool
    step_m: float
    left_cones_xy_m: FloatArray
    right_cones_xy_m: FloatArray
    left_boundary_xy_m: FloatArray
    right_boundary_xy_m: FloatArray

    def __len__(self) -> int:
        return int(self.centre_xy_m.shape[0])

    @property
    def normals(self) -> FloatArray:
        """Unit normals (N, 2) pointing left of the direction of travel."""
        return _normals(self.centre_xy_m, self.closed)

    @property
    def curvature_1pm(self) -> FloatArray:
        """Curvature (N,) of the centreline (1/m), positive turning left."""
        return menger_curvature(self.centre_xy_m, self.closed)

    @property
    def min_width_m(self) -> float:
        """The narrowest width (m) between the boundaries' cone centres."""
        return float(np.min(self.left_width_m + self.right_width_m))

    def free_interval(
        self, left_margin_m: ArrayLike, right_margin_m: ArrayLike, pinch_band_m: float = 0.0
    ) -> tuple[FloatArray, FloatArray]:
        """Offsets (N,) (m, along :attr:`normals`) between which a point keeps at least
        ``left_margin_m`` (N,) from the left boundary and ``right_margin_m`` (N,) from the
        right one. Where no offset does, the offsets whose room (the lesser excess over the
        two margins) is within ``pinch_band_m`` of the most room (with 0, the one offset with
        the most room: on the offset grid, a line pinned there zigzags by a grid step)."""
        lo, hi, _ = self.free_interval_pinched(left_margin_m, right_margin_m, pinch_band_m)
        return lo, hi

    def free_interval_pinched(
        self, left_margin_m: ArrayLike, right_margin_m: ArrayLike, pinch_band_m: float = 0.0
    ) -> tuple[FloatArray, FloatArray, NDArray[np.bool_]]:
        """:meth:`free_interval` and where (N,) no offset keeps both margins."""
        lm = np.broadcast_to(np.asarray(left_margin_m, np.float64), (len(self),))
        rm = np.broadcast_to(np.asarray(right_margin_m, np.float64), (len(self),))
        offsets, inside, to_left, to_right = _room(self.centre_xy_m, self.normals,
                                                   self.left_boundary_xy_m,
                                                   self.right_boundary_xy_m)
        # this stretch of track only: the run of inside points through the centreline (a
        # normal can reach a neighbouring stretch of the lap beyond the boundary)
        in_lo, in_hi = _run_nearest_zero(inside, offsets)
        k = np.arange(len(offsets))[None, :]
        own = (k >= in_lo[:, None]) & (k <= in_hi[:, None]) & inside
        ok = own & (to_left >= lm[:, None]) & (to_right >= rm[:, None])
        lo_idx, hi_idx = _run_nearest_zero(ok, offsets)
        lo, hi = offsets[lo_idx], offsets[hi_idx]
        none = ~ok.any(axis=1)
        if none.any():
            slack = np.where(own, np.minimum(to_left - lm[:, None], to_right - rm[:, None]),
                             -np.inf)
            best_idx = np.argmax(slack[none], axis=1)
            lo[none] = hi[none] = offsets[best_idx]
            if pinch_band_m > 0.0:
                rows = slack[none]
                near = rows >= rows[np.arange(len(rows)), best_idx][:, None] - pinch_band_m
                band_lo, band_hi = _run_through(near, best_idx)
                lo[none], hi[none] = offsets[band_lo], offsets[band_hi]
        return np.asarray(lo, np.float64), np.asarray(hi, np.float64), np.asarray(none, bool)


def _normals(xy: FloatArray, closed: bool) -> FloatArray:
    if closed:
        tangent = np.roll(xy, -1, axis=0) - np.roll(xy, 1, axis=0)
    else:
        tangent = np.gradient(xy, axis=0)
    tangent /= np.maximum(np.linalg.norm(tangent, axis=1, keepdims=True), 1e-12)
    return np.stack([-tangent[:, 1], tangent[:, 0]], axis=1)


def menger_curvature(xy_m: ArrayLike, closed: bool) -> FloatArray:
    """Signed curvature (N,) (1/m) of a polyline (N, 2) through each point and its neighbours
    (the circle through three points); an open polyline's end points copy their neighbours."""
    p = np.asarray(xy_m, np.float64)
    a, b, c = np.roll(p, 1, axis=0), p, np.roll(p, -1, axis=0)
    ab, bc, ac = b - a, c - b, c - a
    cross = ab[:, 0] * bc[:, 1] - ab[:, 1] * bc[:, 0]
    denom = (np.linalg.norm(ab, axis=1) * np.linalg.norm(bc, axis=1)
             * np.linalg.norm(ac, axis=1))
    kappa: FloatArray = 2.0 * cross / np.maximum(denom, 1e-12)
    if not closed and len(p) >= 3:
        kappa[0], kappa[-1] = kappa[1], kappa[-2]
    return kappa


def self_intersects(xy_m: ArrayLike, closed: bool, step_m: float = 2.0) -> bool:
    """Whether a polyline (N, 2) crosses itself (a figure of eight), tested on segments about
    ``step_m`` long (neighbouring segments excepted)."""
    pts = np.asarray(xy_m, np.float64).reshape(-1, 2)
    seg = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    keep = np.r_[0, np.nonzero(np.cumsum(seg) // step_m != np.r_[0, np.cumsum(seg)[:-1]]
                                // step_m)[0] + 1]
    p = pts[np.unique(keep)]
    if closed:
        p = np.vstack([p, p[:1]])
    a, b = p[:-1], p[1:]
    n = len(a)
    if n < 4:
        return False

    def orient(o: FloatArray, u: FloatArray, v: FloatArray) -> FloatArray:
        return (u[..., 0] - o[..., 0]) * (v[..., 1] - o[..., 1]) - \
            (u[..., 1] - o[..., 1]) * (v[..., 0] - o[..., 0])

    ai, bi = a[:, None, :], b[:, None, :]
    aj, bj = a[None, :, :], b[None, :, :]
    cross = ((orient(ai, bi, aj) * orient(ai, bi, bj) < 0.0)
             & (orient(aj, bj, ai) * orient(aj, bj, bi) < 0.0))
    i, j = np.triu_indices(n, k=2)
    gap = j - i
    if closed:
        gap = np.minimum(gap, n - gap)
    return bool(np.any(cross[i, j] & (gap >= 2)))


def _room(
    centre: FloatArray, normals: FloatArray, left: FloatArray, right: FloatArray,
    reach_m: float = OFFSET_RANGE_M,
) -> tuple[FloatArray, NDArray[np.bool_], FloatArray, FloatArray]:
    """At offsets (K,) along each normal, up to ``reach_m`` either side: whether the point is
    between the boundaries (N, K) and its distance to the nearest point of the left and right
    boundary (N, K) each."""
    offsets = np.arange(-reach_m, reach_m + 1e-9, OFFSET_STEP_M)
    pts = centre[:, None, :] + offsets[None, :, None] * normals[:, None, :]
    flat = pts.reshape(-1, 2)
    shape = pts.shape[:2]
    normal_flat = np.repeat(normals, len(offsets), axis=0)
    out = []
    for boundary, sign in ((left, 1.0), (right, -1.0)):
        dist, idx = cKDTree(boundary).query(flat)
        towards = np.sum((boundary[idx] - flat) * normal_flat, axis=1) * sign
        out.append((dist.reshape(shape), towards.reshape(shape) > 0.0))
    (to_left, left_ahead), (to_right, right_ahead) = out
    return offsets, left_ahead & right_ahead, to_left, to_right


def _run_nearest_zero(
    ok: NDArray[np.bool_], offsets: FloatArray
) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Per row of ``ok`` (N, K): the first and last index of the run of True that holds the
    True offset nearest zero (a row with no True gives the index of offset zero twice)."""
    centre = np.where(ok, np.abs(offsets)[None, :], np.inf).argmin(axis=1)
    lo, hi = _run_through(ok, centre)
    zero = int(np.argmin(np.abs(offsets)))
    empty = ~ok.any(axis=1)
    lo[empty] = hi[empty] = zero
    return lo, hi


def _run_through(
    ok: NDArray[np.bool_], centre: NDArray[np.int64]
) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Per row of ``ok`` (N, K): the first and last index of the run of True through the
    index ``centre`` (N,) (True there)."""
    n, k = ok.shape
    idx = np.arange(k)
    last_false = np.maximum.accumulate(np.where(~ok, idx[None, :], -1), axis=1)
    next_false = np.minimum.accumulate(np.where(~ok, idx[None, :], k)[:, ::-1], axis=1)[:, ::-1]
    rows = np.arange(n)
    lo = last_false[rows, centre] + 1
    hi = next_false[rows, centre] - 1
    return lo.astype(np.int64), hi.astype(np.int64)


def _split_sides(
    frame: SplineBaseframe, xy: FloatArray, colours: NDArray[np.int64], max_lateral_m: float
) -> tuple[FloatArray, FloatArray, int]:
    """Cones of each side (left, right) in order along ``frame``, and how many were dropped
    (too far from the guide, or on the side their colour contradicts)."""
    s, d = frame.project_many(xy)
    near = np.abs(d) <= max_lateral_m
    blue = colours == int(ConeColour.BLUE)
    yellow = colours == int(ConeColour.YELLOW)
    # a coloured cone on the wrong side of the guide is another branch's or a mapping error
    left = near & (blue | (~yellow & (d > 0.0))) & ~(blue & (d < -0.5))
    right = near & (yellow | (~blue & (d < 0.0))) & ~(yellow & (d > 0.5))
    dropped = int(len(xy) - left.sum() - right.sum())
    sides = []
    for mask in (left, right):
        order = np.argsort(s[mask], kind="stable")
        sides.append(xy[mask][order])
    return sides[0], sides[1], dropped


def _densify(points: FloatArray, closed: bool, step_m: float) -> FloatArray:
    """Points along the polyline through ``points`` at most ``step_m`` apart."""
    if len(points) < 2:
        return points
    pts = np.vstack([points, points[:1]]) if closed else points
    out = [pts[:1]]
    for a, b in zip(pts[:-1], pts[1:], strict=True):
        n = max(int(np.ceil(np.linalg.norm(b - a) / step_m)), 1)
        t = np.arange(1, n + 1)[:, None] / n
        out.append(a + t * (b - a))
    return np.vstack(out)


def _boundaries(
    frame: SplineBaseframe, left: FloatArray, right: FloatArray, closed: bool,
    nominal_width_m: float,
) -> tuple[FloatArray, FloatArray]:
    """Both boundaries sampled densely; a side with fewer than three cones is the other side
    moved across by ``nominal_width_m`` along the guide's normals."""
    dense = [_densify(side, closed, BOUNDARY_STEP_M) if len(side) >= 3 else None
             for side in (left, right)]
    if dense[0] is None and dense[1] is None:
        raise TrackError(f"track model: {len(left)} left and {len(right)} right cones")
    for k, sign in ((0, 1.0), (1, -1.0)):
        if dense[k] is None:
            other = dense[1 - k]
            assert other is not None
            s, d = frame.project_many(other)
            dense[k] = frame.frenet_to_xy(s, d + sign * nominal_width_m)
    assert dense[0] is not None and dense[1] is not None
    return dense[0], dense[1]


def side_boundaries(frame: SplineBaseframe, cones_xy_m: FloatArray, colours: NDArray[np.int64],
                    max_lateral_m: float, nominal_width_m: float
                    ) -> tuple[FloatArray, FloatArray]:
    """The left and right boundaries along the open or closed ``frame`` (dense polylines (P, 2)
    and (Q, 2)) from the cones (N, 2) with their :class:`ConeColour` (N,) within
    ``max_lateral_m`` of it, as :func:`track_from_cones` builds them. Raises
    :class:`TrackError` when neither side has three cones."""
    left, right, _ = _split_sides(frame, cones_xy_m, colours, max_lateral_m)
    return _boundaries(frame, left, right, frame.closed, nominal_width_m)


def most_room_offsets(centre_xy_m: FloatArray, normals: FloatArray, left_xy_m: FloatArray,
                      right_xy_m: FloatArray, left_margin_m: ArrayLike, right_margin_m: ArrayLike,
                      reach_m: float) -> FloatArray:
    """Per sample of ``centre_xy_m`` (N, 2), the offset (N,) (m, along ``normals``, within
    ``reach_m``) between the boundary polylines ``left_xy_m`` and ``right_xy_m`` at which the
    lesser of the room to the left less ``left_margin_m`` (N,) and the room to the right less
    ``right_margin_m`` (N,) is largest (0 where no offset lies between them)."""
    offsets, inside, to_left, to_right = _room(centre_xy_m, normals, left_xy_m, right_xy_m,
                                               reach_m)
    lm = np.asarray(left_margin_m, np.float64).reshape(-1, 1)
    rm = np.asarray(right_margin_m, np.float64).reshape(-1, 1)
    slack = np.where(inside, np.minimum(to_left - lm, to_right - rm), -np.inf)
    best = offsets[np.argmax(slack, axis=1)]
    best[~inside.any(axis=1)] = 0.0
    return np.asarray(best, np.float64)


def track_from_cones(
    cones_xy_m: ArrayLike,
    colours: ArrayLike,
    guide_xy_m: ArrayLike,
    closed: bool = True,
    *,
    step_m: float = 1.0,
    max_lateral_m: float = 6.0,
    nominal_width_m: float = 3.5,
    smoothing_m: float = 2.0,
    iterations: int = 3,
) -> TrackModel:
    """The track along ``guide_xy_m`` (K, 2) (in order of travel; ``closed`` for a lap) from the
    cones (N, 2) with their :class:`ConeColour` (N,). Raises :class:`TrackError` when neither
    side has three cones or the guide is too short for a frame."""
    xy = np.asarray(cones_xy_m, np.float64).reshape(-1, 2)
    col = np.asarray(colours, np.int64).reshape(-1)
    finite = np.all(np.isfinite(xy), axis=1)
    xy, col = xy[finite], col[finite]
    frame = SplineBaseframe(guide_xy_m, closed, resample_m=1.0, smoothing_m=smoothing_m,
                            step_m=step_m)
    left, right, dropped = _split_sides(frame, xy, col, max_lateral_m)
    if dropped:
        logger.info("track model: %d of %d cones belong to neither side", dropped, len(xy))
    left_dense, right_dense = _boundaries(frame, left, right, closed, nominal_width_m)
    for _ in range(max(iterations, 1)):
        centre, normals = frame.xy_m, _normals(frame.xy_m, closed)
        offsets, inside, to_left, to_right = _room(centre, normals, left_dense, right_dense)
        # the middle: the offset inside the track equally far from both boundaries
        in_lo, in_hi = _run_nearest_zero(inside, offsets)
        k = np.arange(len(offsets))[None, :]
        own = (k >= in_lo[:, None]) & (k <= in_hi[:, None]) & inside
        imbalance = np.where(own, np.abs(to_left - to_right), np.inf)
        middle = offsets[np.argmin(imbalance, axis=1)]
        middle[~inside.any(axis=1)] = 0.0
        frame = SplineBaseframe(centre + middle[:, None] * normals, closed, resample_m=step_m,
                                smoothing_m=smoothing_m, step_m=step_m)
    centre = frame.xy_m
    left_w = cKDTree(left_dense).query(centre)[0]
    right_w = cKDTree(right_dense).query(centre)[0]
    return TrackModel(centre, np.asarray(left_w, np.float64), np.asarray(right_w, np.float64),
                      closed, frame.step_m, left, right, left_dense, right_dense)
