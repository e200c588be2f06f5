"""The racing line: the path of least curvature inside the track (as TUM's
``trajectory_planning_helpers.opt_min_curv``, solved here as bounded least squares).

The line is the centreline moved along its normals by offsets alpha (N,), each bounded so that the
car's body, with a margin, stays inside the boundaries. The sum of squared curvatures is
minimised by Gauss-Newton steps: the curvature of the line at a sample depends only on the
offsets of that sample and its two neighbours, so its Jacobian is tridiagonal (cyclic on a loop)
and each step is a sparse bounded linear least-squares problem (``scipy.optimize.lsq_linear``).

The margin follows the car's geometry: the rear axle (the vehicle origin) runs on the line; the
inside of a bend needs half the car's width, the outside half the width plus what the front
corner swings out beyond it on a bend of the centreline's radius.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import minimize
from scipy.sparse import coo_matrix

from planner.baseframe import SplineBaseframe
from planner.speed_profile import SpeedLimits, forward_backward_speed_mps, lap_time_s
from planner.track_model import TrackModel, menger_curvature

logger = logging.getLogger(__name__)

FloatArray = NDArray[np.float64]
SpeedCap = Callable[[FloatArray], FloatArray]
"""A speed limit (m/s) from a line's curvature (1/m), per sample."""

PINCH_BAND_M = 0.1
"""Where the track is narrower than the car and its margins, the line may lie anywhere with
room within this of the most (a line pinned to the most room follows every wobble of the
boundaries)."""

LENGTH_WEIGHTS = (0.0, 1.0, 2.0, 4.0, 8.0, 16.0)
"""Weights of the path length against the curvature tried for the racing line."""


def body_margins_m(
    kappa_1pm: FloatArray, half_width_m: float, front_m: float, clearance_m: float
) -> tuple[FloatArray, FloatArray]:
    """Distance (m) the line must keep from the left and right boundary (N,) each.

    ``front_m``: rear axle to the front of the car; ``clearance_m``: cone radius plus a margin.
    On a bend of radius R the front outer corner lies sqrt((R + w/2)^2 + f^2) from the centre
    of the bend, i.e. w/2 + f^2 / (sqrt((R + w/2)^2 + f^2) + R + w/2) outside the line.
    """
    k = np.asarray(kappa_1pm, np.float64)
    radius = 1.0 / np.maximum(np.abs(k), 1e-6)
    outer_arm = radius + half_width_m
    outer = half_width_m + front_m**2 / (np.sqrt(outer_arm**2 + front_m**2) + outer_arm)
    outer = outer + clearance_m
    inner = np.full_like(k, half_width_m + clearance_m)
    left = np.where(k < 0.0, outer, inner)  # turning right: the left side is the outside
    right = np.where(k > 0.0, outer, inner)
    return left, right


def _colours(n: int) -> NDArray[np.int64]:
    """A colouring of a cyclic chain in which any three consecutive indices differ."""
    colour = np.arange(n) % 3
    tail = n % 3
    if tail:
        colour[n - tail:] = 3 + np.arange(tail)
    return colour


def _jacobian(centre: FloatArray, normals: FloatArray, alpha: FloatArray, closed: bool,
              step: float = 1e-4) -> coo_matrix:
    """d kappa_i / d alpha_j (N, N), non-zero for |i - j| <= 1 (cyclically when closed)."""
    n = len(alpha)
    base = menger_curvature(centre + alpha[:, None] * normals, closed)
    colour = _colours(n)
    rows: list[NDArray[np.int64]] = []
    cols: list[NDArray[np.int64]] = []
    vals: list[FloatArray] = []
    idx = np.arange(n)
    for c in range(int(colour.max()) + 1):
        moved = colour == c
        trial = alpha + step * moved
        dk = (menger_curvature(centre + trial[:, None] * normals, closed) - base) / step
        for shift in (-1, 0, 1):
            j = idx + shift
            if closed:
                j = np.mod(j, n)
            ok = (j >= 0) & (j < n)
            ok[ok] &= moved[j[ok]]
            rows.append(idx[ok])
            cols.append(j[ok])
            vals.append(dk[ok])
    return coo_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                      shape=(n, n))


def _next(a: FloatArray) -> FloatArray:
    """``np.roll(a, -1)`` of a 1-D array (element i is a[i + 1], cyclic), without roll's
    per-call overhead (the racing line calls this hundreds of thousands of times)."""
    out = np.empty_like(a)
    out[:-1] = a[1:]
    out[-1:] = a[:1]
    return out


def _prev(a: FloatArray) -> FloatArray:
    """``np.roll(a, 1)`` of a 1-D array (element i is a[i - 1], cyclic)."""
    out = np.empty_like(a)
    out[1:] = a[:-1]
    out[:1] = a[-1:]
    return out


def _menger_xy(x: FloatArray, y: FloatArray, closed: bool) -> FloatArray:
    """:func:`planner.track_model.menger_curvature` of the polyline (x, y) (N,) each, bit for
    bit (the same operations on each element), with the coordinates apart and each segment's
    difference and length computed once (point i's segment in is point i-1's segment out)."""
    x_next, y_next = _next(x), _next(y)
    ex = x_next - x  # c - b at each point: point i to i+1
    ey = y_next - y
    bx, by = _prev(ex), _prev(ey)  # b - a: point i-1 to i
    acx = x_next - _prev(x)
    acy = y_next - _prev(y)
    cross = bx * ey - by * ex
    out_len = np.sqrt(ex * ex + ey * ey)
    denom = _prev(out_len) * out_len * np.sqrt(acx * acx + acy * acy)
    kappa: FloatArray = 2.0 * cross / np.maximum(denom, 1e-12)
    if not closed and len(x) >= 3:
        kappa[0], kappa[-1] = kappa[1], kappa[-2]
    return kappa


class _CurvatureGradient:
    """sum(kappa^2) and its gradient for offsets alpha along ``normals``: what
    ``menger_curvature`` and ``_jacobian(...).T @ (2 kappa)`` give, bit for bit, without
    building a sparse matrix per evaluation.

    The Jacobian's structure (which colour moves which column, the rows of each column) depends
    only on N, so it is found once. Column j of the Jacobian holds d kappa_i / d alpha_j for
    i in j-1, j, j+1 (cyclic when closed); the sparse product sums those terms in increasing i,
    from 0, and so does :meth:`gradient`. Needs N >= 4 (fewer: use ``_jacobian``)."""

    def __init__(self, centre: FloatArray, normals: FloatArray, closed: bool,
                 step: float = 1e-4) -> None:
        n = len(centre)
        self.cx, self.cy = np.ascontiguousarray(centre[:, 0]), np.ascontiguousarray(centre[:, 1])
        self.nx, self.ny = np.ascontiguousarray(normals[:, 0]), np.ascontiguousarray(normals[:, 1])
        self.closed = closed
        self.step = step
        colour = _colours(n)
        self.bumps = [step * (colour == c) for c in range(int(colour.max()) + 1)]
        idx = np.arange(n)
        rows = np.stack([idx - 1, idx, idx + 1], axis=1)  # rows of column j
        if closed:
            rows = np.sort(np.mod(rows, n), axis=1)
            self.full = np.ones(n, bool)
        else:
            # the end columns have two rows: the missing one's slot repeats a valid row and is
            # left out of the sum
            self.full = (idx > 0) & (idx < n - 1)
            rows = np.where(rows < 0, 0, rows)
            rows = np.where(rows > n - 1, n - 1, rows)
            rows[0] = [0, 1, 1]
        self.rows = rows
        self.colour = colour

    def line(self, alpha: FloatArray) -> tuple[FloatArray, FloatArray]:
        """The line's x and y (N,) each for offsets ``alpha``."""
        return self.cx + alpha * self.nx, self.cy + alpha * self.ny

    def gradient(self, alpha: FloatArray, kappa: FloatArray) -> FloatArray:
        """d sum(kappa^2) / d alpha (N,), ``kappa`` the line's curvature at ``alpha``."""
        dks = []
        for bump in self.bumps:
            trial = alpha + bump
            x, y = self.line(trial)
            dks.append((_menger_xy(x, y, self.closed) - kappa) / self.step)
        jac = np.stack(dks)[self.colour[:, None], self.rows]  # J[rows[j, k], j]
        v = 2.0 * kappa
        terms = jac * v[self.rows]
        grad: FloatArray = 0.0 + terms[:, 0]
        grad = grad + terms[:, 1]
        grad[self.full] = grad[self.full] + terms[self.full, 2]
        return grad


def _length_gradient(line: FloatArray, normals: FloatArray, closed: bool) -> FloatArray:
    """d (polyline length) / d alpha_j (N,) for a line moved along ``normals``."""
    seg = np.roll(line, -1, axis=0) - line
    unit = seg / np.maximum(np.linalg.norm(seg, axis=1, keepdims=True), 1e-12)
    if not closed:
        unit[-1] = 0.0
    before = np.roll(unit, 1, axis=0)  # segment j-1 -> j
    if not closed:
        before[0] = 0.0
    return np.asarray(np.sum((before - unit) * normals, axis=1), np.float64)


def _polyline_length(line: FloatArray, closed: bool) -> float:
    pts = np.vstack([line, line[:1]]) if closed else line
    return float(np.sum(np.linalg.norm(np.diff(pts, axis=0), axis=1)))


def min_curvature_offsets(
    centre_xy_m: FloatArray,
    normals: FloatArray,
    lower_m: FloatArray,
    upper_m: FloatArray,
    closed: bool = True,
    *,
    length_weight: float = 0.0,
    max_iterations: int = 400,
    start_m: FloatArray | None = None,
) -> FloatArray:
    """Offsets alpha (N,) (m, along ``normals``) within [lower, upper] that minimise

        sum(kappa^2) / sum(kappa_0^2) + length_weight * length / length_0

    for the line ``centre + alpha normals`` (kappa_0, length_0: of the centreline): the least
    curved line, with ``length_weight`` > 0 trading curvature for a shorter path. Where
    lower > upper (the track is narrower than the car and margins) the offset is pinned to the
    middle of the two. Solved with L-BFGS-B (bounds), the gradient from the tridiagonal
    Jacobian of the curvature. ``start_m``: offsets to start the descent from (default the
    centreline), e.g. the solution for a neighbouring ``length_weight``."""
    lo = np.asarray(lower_m, np.float64).copy()
    hi = np.asarray(upper_m, np.float64).copy()
    pinch = lo > hi
    mid = 0.5 * (lo + hi)
    lo[pinch] = hi[pinch] = mid[pinch]
    k0 = menger_curvature(centre_xy_m, closed)
    k_scale = max(float(np.sum(k0**2)), 1e-9)
    l_scale = max(_polyline_length(centre_xy_m, closed), 1e-9)

    fast = _CurvatureGradient(centre_xy_m, normals, closed) if len(lo) >= 4 else None

    def cost(alpha: FloatArray) -> tuple[float, FloatArray]:
        if fast is not None:
            kappa = _menger_xy(*fast.line(alpha), closed)
            grad = fast.gradient(alpha, kappa) / k_scale
        else:
            kappa = menger_curvature(centre_xy_m + alpha[:, None] * normals, closed)
            jac = _jacobian(centre_xy_m, normals, alpha, closed).tocsr()
            grad = np.asarray(jac.T @ (2.0 * kappa), np.float64) / k_scale
        value = float(np.sum(kappa**2)) / k_scale
        if length_weight > 0.0:
            line = centre_xy_m + alpha[:, None] * normals
            value += length_weight * _polyline_length(line, closed) / l_scale
            grad += length_weight * _length_gradient(line, normals, closed) / l_scale
        return value, grad

    start = np.clip(np.zeros(len(lo)) if start_m is None else start_m, lo, hi)
    result = minimize(cost, start, jac=True, method="L-BFGS-B", bounds=list(zip(lo, hi,
                      strict=True)), options={"maxiter": max_iterations, "ftol": 1e-10})
    return np.clip(np.asarray(result.x, np.float64), lo, hi)


def min_curvature_offsets_ls(
    centre_xy_m: FloatArray,
    normals: FloatArray,
    lower_m: FloatArray,
    upper_m: FloatArray,
    closed: bool = False,
    iterations: int = 3,
) -> FloatArray:
    """Offsets alpha (N,) (m, along ``normals``) within [lower, upper] that minimise the sum
    of squared curvatures of ``centre + alpha normals``, by a few Gauss-Newton steps, each a
    small dense bounded least-squares problem (:func:`bounded_least_squares`): for the short
    lines of a plan, where :func:`min_curvature_offsets`' quasi-Newton descent takes a
    hundred-odd steps. An offset with lower >= upper is held at the middle of the two; an
    open line's end points (whose curvature copies their neighbours') are not counted."""
    lo = np.asarray(lower_m, np.float64)
    hi = np.asarray(upper_m, np.float64)
    held = lo >= hi
    alpha = np.where(held, 0.5 * (lo + hi), np.clip(0.0, lo, hi))
    free = ~held
    if not np.any(free):
        return alpha
    rows = slice(None) if closed else slice(1, len(alpha) - 1)
    for _ in range(iterations):
        kappa = menger_curvature(centre_xy_m + alpha[:, None] * normals, closed)
        jac = _jacobian(centre_xy_m, normals, alpha, closed).toarray()[rows][:, free]
        target = jac @ alpha[free] - kappa[rows]
        alpha[free] = np.clip(bounded_least_squares(jac, target, lo[free], hi[free]),
                              lo[free], hi[free])
    return alpha


def bounded_least_squares(a: FloatArray, b: FloatArray, lower: FloatArray,
                          upper: FloatArray) -> FloatArray:
    """x (N,) within [lower, upper] (N,) that minimises |a x - b|^2 (``a`` (M, N), ``b`` (M,)),
    as the quadratic program 1/2 x' (a'a) x - (a'b)' x, solved by DAQP's dual active set
    (0.1-0.2 ms on a plan's 30-40 offsets, the same x to 1e-13 as scipy's ``lsq_linear``
    bvls, which took 3-10 ms); bvls when DAQP reports no optimum (a'a is singular where the
    ends are free: DAQP regularises it)."""
    import daqp  # local: only the plan's line needs it

    n = a.shape[1]
    x, _, exit_flag, _ = daqp.solve(a.T @ a, -(a.T @ b), np.zeros((0, n)),
                                    np.array(upper, np.float64), np.array(lower, np.float64),
                                    np.zeros(n, np.int32))
    if exit_flag == 1:  # optimal
        return np.asarray(x, np.float64)
    from scipy.optimize import lsq_linear

    logger.warning("daqp exit flag %d on a %d-offset line: solved by bvls", exit_flag, n)
    return np.asarray(lsq_linear(a, b, bounds=(lower, upper), method="bvls").x, np.float64)


def line_lap_time_s(line_xy_m: FloatArray, closed: bool, limits: SpeedLimits,
                    speed_cap: SpeedCap | None = None) -> float:
    """Time (s) a point mass with ``limits`` needs along ``line_xy_m`` (N, 2) (a flying lap
    when closed, from and to standstill when open); ``speed_cap`` gives a further limit (m/s)
    from the line's curvature (1/m), such as the steering lock's."""
    frame = SplineBaseframe(line_xy_m, closed, resample_m=1.0, smoothing_m=1.0, step_m=0.5)
    ds = np.full(len(frame.s_m) if closed else len(frame.s_m) - 1, frame.step_m)
    kappa = frame.curvature_1pm
    v = forward_backward_speed_mps(kappa, ds, limits, closed,
                                   v_start_mps=None if closed else 0.0,
                                   v_end_mps=None if closed else 0.0,
                                   v_limit_mps=None if speed_cap is None else speed_cap(kappa))
    return lap_time_s(v, ds, closed)


def _search_weights(timed: Callable[[int], float], n: int) -> None:
    """Call ``timed(i)`` for the indices of ``n`` length weights a descent needs: the lap time
    against the weight falls to one least and rises after it, so from the middle two the
    search walks downhill and stops at the first rise (3-4 solves of 6, not all; issue 42).
    Only when every time is infinite (no line at all) is every weight tried."""
    if n <= 2:
        for i in range(n):
            timed(i)
        return
    i, j = n // 2 - 1, n // 2
    step, best = (1, j) if timed(j) < timed(i) else (-1, i)
    k = best + step
    while 0 <= k < n:
        if not timed(k) < timed(best):
            break
        best, k = k, k + step
    if not math.isfinite(timed(best)):
        for k in range(n):
            timed(k)


def racing_line(
    track: TrackModel,
    *,
    half_width_m: float,
    front_m: float,
    clearance_m: float,
    limits: SpeedLimits,
    speed_cap: SpeedCap | None = None,
    length_weights: tuple[float, ...] = LENGTH_WEIGHTS,
) -> tuple[FloatArray, FloatArray]:
    """The racing line (N, 2) inside ``track`` and its offsets from the centreline (N,).

    For a car of half width ``half_width_m`` whose front is ``front_m`` ahead of the rear axle,
    keeping ``clearance_m`` (cone radius plus margin) from the boundaries. Lines of least
    curvature with each of ``length_weights`` are timed with ``limits`` (a point mass); the
    fastest is the racing line (least curvature alone is slow where the track is one long bend:
    the outside is longer), with ``speed_cap`` (m/s from the curvature, e.g. the steering
    lock's: a tight inside line the car cannot steer is not fast)."""
    normals = track.normals
    kappa = track.curvature_1pm
    left_margin, right_margin = body_margins_m(kappa, half_width_m, front_m, clearance_m)
    lower, upper, pinched = track.free_interval_pinched(left_margin, right_margin,
                                                        pinch_band_m=PINCH_BAND_M)
    narrow = int(np.sum(pinched))
    if narrow:
        logger.info("racing line: %d of %d samples narrower than the car and margins",
                    narrow, len(track))
    tried: dict[int, tuple[float, FloatArray | None]] = {}

    def timed(i: int) -> float:
        """The lap time (s) of the line with ``length_weights[i]`` (inf: no line)."""
        if i not in tried:
            weight = length_weights[i]
            # from the solution of the nearest weight tried: a few steps from this one's
            near = [(abs(j - i), a) for j, (_, a) in tried.items() if a is not None]
            alpha = min_curvature_offsets(track.centre_xy_m, normals, lower, upper,
                                          track.closed, length_weight=weight,
                                          start_m=min(near, key=lambda p: p[0])[1]
                                          if near else None)
            line = track.centre_xy_m + alpha[:, None] * normals
            if np.all(np.isfinite(line)):
                t = line_lap_time_s(line, track.closed, limits, speed_cap)
                logger.debug("racing line: length weight %.2f: %.3f s", weight, t)
                tried[i] = (t, alpha)
            else:
                tried[i] = (math.inf, None)
        return tried[i][0]

    _search_weights(timed, len(length_weights))
    best: tuple[float, FloatArray, float] | None = None
    for i, (t, alpha) in sorted(tried.items()):  # the smallest weight of equal times
        if alpha is not None and (best is None or t < best[0]):
            best = (t, alpha, length_weights[i])
    if best is None:
        logger.warning("racing line: no solution: the centreline")
        return track.centre_xy_m.copy(), np.zeros(len(track))
    t_best, alpha, weight = best
    line = track.centre_xy_m + alpha[:, None] * normals
    centre = track.centre_xy_m
    t_centre = line_lap_time_s(centre, track.closed, limits, speed_cap)
    logger.info("racing line: %.2f s (centreline %.2f s), length weight %.2f, max |kappa| "
                "%.3f -> %.3f 1/m", t_best, t_centre, weight, float(np.max(np.abs(kappa))),
                float(np.max(np.abs(menger_curvature(line, track.closed)))))
    if t_centre <= t_best:
        # the room is narrow and jagged (the boundaries' chords between cones): the line zigzags
        logger.warning("racing line: slower than the centreline (%.2f s against %.2f s): the "
                       "centreline", t_best, t_centre)
        return centre.copy(), np.zeros(len(track))
    return line, alpha
