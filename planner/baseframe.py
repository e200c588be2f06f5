"""The baseframe: a smoothed cubic spline through the waypoints (seed 002, 3.2.2 and 3.5).

The waypoints are resampled evenly by chord length, smoothed with a Gaussian along the path (so
noisy waypoints do not make curvature spikes) and fitted with a scipy ``CubicSpline`` (periodic for
a lap). The curve is then sampled evenly in true arc length ``s`` with position, heading and
curvature. A Frenet projection gives (s, d) for any point, d positive to the left.
"""

from __future__ import annotations

import logging
import math

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.interpolate import CubicSpline
from scipy.ndimage import gaussian_filter1d
from scipy.spatial import cKDTree

from common.conventions import wrap_angles
from common.errors import TrackError
from common.messages import Baseframe, ConeColour

logger = logging.getLogger(__name__)

FloatArray = NDArray[np.float64]


def _dedupe(points: FloatArray, closed: bool, min_gap_m: float = 1e-3) -> FloatArray:
    """Drop non-finite rows and consecutive duplicates (and a closing duplicate for a loop)."""
    points = points[np.all(np.isfinite(points), axis=1)]
    if len(points) == 0:
        return points
    keep = np.ones(len(points), bool)
    keep[1:] = np.linalg.norm(np.diff(points, axis=0), axis=1) > min_gap_m
    points = points[keep]
    if closed and len(points) > 1 and np.linalg.norm(points[-1] - points[0]) <= min_gap_m:
        points = points[:-1]
    return points


def _resample(points: FloatArray, closed: bool, step_m: float) -> FloatArray:
    """Resample a polyline evenly (about ``step_m`` apart) along an interpolating cubic spline
    through it (linear resampling would cut the corners of a coarse polyline)."""
    pts = np.vstack([points, points[:1]]) if closed else points
    seg = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    u = np.concatenate([[0.0], np.cumsum(seg)])
    total = float(u[-1])
    n = max(int(round(total / step_m)), 8 if closed else 4)
    u_new = np.linspace(0.0, total, n, endpoint=not closed)
    if len(pts) >= (4 if closed else 3):
        spline = CubicSpline(u, pts, bc_type="periodic" if closed else "natural")
        return np.asarray(spline(u_new), np.float64)
    return np.stack([np.interp(u_new, u, pts[:, 0]), np.interp(u_new, u, pts[:, 1])], axis=1)


def _smooth(points: FloatArray, closed: bool, sigma: float) -> FloatArray:
    """Gaussian smoothing along the path with twicing (2 G(p) - G(G(p))): noise is removed while
    the shrinking of curves that a plain Gaussian causes is cancelled to second order."""
    mode = "wrap" if closed else "nearest"
    once = gaussian_filter1d(points, sigma, axis=0, mode=mode)
    twice = gaussian_filter1d(once, sigma, axis=0, mode=mode)
    out: FloatArray = 2.0 * once - twice
    if not closed:  # keep the ends where they were
        out[0], out[-1] = points[0], points[-1]
    return out


def _smooth_in_bends(points: FloatArray, closed: bool, spacing_m: float, smoothing_m: float,
                     sigma_per_radius: float) -> FloatArray:
    """:func:`_smooth` with a standard deviation of at most ``sigma_per_radius`` times the local
    bend radius (m), ``smoothing_m`` on straights and open bends.

    A Gaussian as wide as the bend is round cuts inside it (2.5 m on a 3 m radius: 0.3 m, a
    third of what a hairpin leaves the car), while a narrower one everywhere keeps the zig-zag
    of cone pairs far apart along the track. The radius is measured on the path smoothed at
    full width (the zig-zag gone, the bend still there); each point takes the path smoothed with
    its own deviation, interpolated between a few widths."""
    widths_m = smoothing_m * np.array([1.0, 0.7, 0.5, 0.35, 0.25])
    layers = [_smooth(points, closed, w / spacing_m) for w in widths_m]
    wide = layers[0]
    kappa = np.zeros(len(points))
    if closed:
        step = np.roll(wide, -1, axis=0) - wide  # step i: point i to i+1
        heading = np.arctan2(step[:, 1], step[:, 0])
        turn = np.abs(wrap_angles(heading - np.roll(heading, 1)))  # at point i
        kappa = turn / np.maximum(np.linalg.norm(step, axis=1), 1e-9)
    elif len(points) >= 3:
        step = np.diff(wide, axis=0)
        heading = np.arctan2(step[:, 1], step[:, 0])
        kappa[1:-1] = (np.abs(wrap_angles(np.diff(heading)))
                       / np.maximum(np.linalg.norm(step[1:], axis=1), 1e-9))
    kappa = gaussian_filter1d(kappa, 1.0 / spacing_m, mode="wrap" if closed else "nearest")
    wanted_m = np.clip(sigma_per_radius / np.maximum(kappa, 1e-9), widths_m[-1], widths_m[0])
    # widths_m falls: interpolate each point's place among the layers
    place = np.interp(-wanted_m, -widths_m, np.arange(len(widths_m), dtype=np.float64))
    low = np.floor(place).astype(int)
    high = np.minimum(low + 1, len(widths_m) - 1)
    frac = (place - low)[:, None]
    stack = np.stack(layers)
    idx = np.arange(len(points))
    out: FloatArray = (1.0 - frac) * stack[low, idx] + frac * stack[high, idx]
    return out


class SplineBaseframe:
    """A cubic spline baseframe through waypoints, sampled every ``step_m`` of arc length.

    ``points_xy_m`` (N, 2) in order of travel; ``closed`` for a lap (periodic spline).
    ``resample_m`` None fits the points as given; ``smoothing_m`` is the Gaussian's standard
    deviation along the path (0: none), at most ``sigma_per_radius`` times the radius of a bend
    (0: the same everywhere). Raises :class:`TrackError` with too few points.
    """

    def __init__(
        self,
        points_xy_m: ArrayLike,
        closed: bool = True,
        *,
        resample_m: float | None = 1.0,
        smoothing_m: float = 2.5,
        step_m: float = 0.25,
        sigma_per_radius: float = 0.5,
    ) -> None:
        pts = _dedupe(np.asarray(points_xy_m, np.float64).reshape(-1, 2), closed)
        if len(pts) < (4 if closed else 2):
            raise TrackError(f"baseframe needs at least 4 waypoints, got {len(pts)}")
        self.closed = bool(closed)
        if resample_m is not None:
            pts = _resample(pts, closed, resample_m)
            spacing = resample_m
        else:
            spacing = float(np.mean(np.linalg.norm(np.diff(pts, axis=0), axis=1)))
        if smoothing_m > 0.0 and len(pts) >= 4:
            spacing = max(spacing, 1e-6)
            if sigma_per_radius > 0.0:
                smoothed = _smooth_in_bends(pts, closed, spacing, smoothing_m, sigma_per_radius)
            else:
                smoothed = _smooth(pts, closed, smoothing_m / spacing)
            pts = _dedupe(smoothed, closed)
        if closed:
            knots = np.vstack([pts, pts[:1]])
        else:
            knots = pts
        seg = np.linalg.norm(np.diff(knots, axis=0), axis=1)
        u = np.concatenate([[0.0], np.cumsum(seg)])
        if len(knots) == 2:  # a straight segment: a line
            knots = np.vstack([knots[0], knots.mean(axis=0), knots[1]])
            u = np.array([0.0, u[1] / 2, u[1]])
        spline = CubicSpline(u, knots, bc_type="periodic" if closed else "natural")
        # true arc length on a fine grid, then even samples in s
        n_fine = max(int(u[-1] / (step_m / 4.0)), 16)
        u_fine = np.linspace(0.0, u[-1], n_fine + 1)
        speed = np.linalg.norm(spline(u_fine, 1), axis=1)
        seg_len = 0.5 * (speed[1:] + speed[:-1]) * np.diff(u_fine)
        s_fine = np.concatenate([[0.0], np.cumsum(seg_len)])
        self.length_m = float(s_fine[-1])
        n = max(int(round(self.length_m / step_m)), 4)
        s = np.linspace(0.0, self.length_m, n + 1)  # last sample = s 0 again when closed
        uu = np.interp(s, s_fine, u_fine)
        p, d1, d2 = spline(uu), spline(uu, 1), spline(uu, 2)
        speed_u = np.maximum(np.linalg.norm(d1, axis=1), 1e-9)
        heading = np.unwrap(np.arctan2(d1[:, 1], d1[:, 0]))
        kappa = (d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]) / speed_u**3
        self._s = s
        self._x = p[:, 0]
        self._y = p[:, 1]
        self._heading_unwrapped = heading
        self._kappa = kappa
        m = n if closed else n + 1  # samples without the closing duplicate
        self._tree = cKDTree(np.stack([self._x[:m], self._y[:m]], axis=1))
        self._m = m
        self.step_m = float(self.length_m / n)

    # ------------------------------------------------------------------ samples
    @property
    def s_m(self) -> FloatArray:
        """Arc length of the samples (M,) (m), without the closing duplicate of a loop."""
        return self._s[: self._m]

    @property
    def xy_m(self) -> FloatArray:
        """Sample positions (M, 2) (m)."""
        return np.stack([self._x[: self._m], self._y[: self._m]], axis=1)

    @property
    def heading_rad(self) -> FloatArray:
        """Sample headings (M,) wrapped to (-pi, pi]."""
        return wrap_angles(self._heading_unwrapped[: self._m])

    @property
    def curvature_1pm(self) -> FloatArray:
        """Sample curvatures (M,) (1/m), positive turning left."""
        return self._kappa[: self._m]

    def _wrap_s(self, s_m: ArrayLike) -> FloatArray:
        s = np.asarray(s_m, np.float64)
        if self.closed:
            return np.mod(s, self.length_m)
        return np.clip(s, 0.0, self.length_m)

    def sample(self, s_m: ArrayLike) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        """Position x, y (m), heading (rad, wrapped) and curvature (1/m) at arc lengths ``s_m``."""
        s = self._wrap_s(s_m)
        x = np.interp(s, self._s, self._x)
        y = np.interp(s, self._s, self._y)
        h = wrap_angles(np.interp(s, self._s, self._heading_unwrapped))
        k = np.interp(s, self._s, self._kappa)
        return x, y, h, k

    def frenet_to_xy(self, s_m: ArrayLike, d_m: ArrayLike) -> FloatArray:
        """Frenet (s along, d left of the baseframe) to world x, y: (..., 2)."""
        x, y, h, _ = self.sample(s_m)
        d = np.asarray(d_m, np.float64)
        return np.stack([x - d * np.sin(h), y + d * np.cos(h)], axis=-1)

    def project(
        self, x_m: float, y_m: float, s_hint_m: float | None = None, window_m: float = 15.0
    ) -> tuple[float, float]:
        """Frenet coordinates (s, d) of a point; d > 0 left of the baseframe.

        With ``s_hint_m`` only samples within ``window_m`` of the hint are searched, so a crossing
        baseframe (skidpad) projects onto the branch being driven.
        """
        if s_hint_m is not None and math.isfinite(s_hint_m):
            half = int(window_m / self.step_m)
            centre = int(round(float(self._wrap_s(s_hint_m)) / self.step_m))
            idx = np.arange(centre - half, centre + half + 1)
            idx = np.mod(idx, self._m) if self.closed else idx[(idx >= 0) & (idx < self._m)]
            d2 = (self._x[idx] - x_m) ** 2 + (self._y[idx] - y_m) ** 2
            i = int(idx[int(np.argmin(d2))])
        else:
            _, i = self._tree.query([x_m, y_m])
            i = int(i)
        best: tuple[float, float, float] | None = None
        for j in (i - 1, i):
            a, b = j, j + 1
            if self.closed:
                a, b = a % self._m, b % self._m
                if b == 0:
                    b = self._m  # the closing duplicate sample
            elif a < 0 or b > self._m - 1:
                continue
            ax, ay, bx, by = self._x[a], self._y[a], self._x[b], self._y[b]
            vx, vy = bx - ax, by - ay
            seg2 = vx * vx + vy * vy
            t = 0.0 if seg2 <= 0 else min(max(((x_m - ax) * vx + (y_m - ay) * vy) / seg2, 0.0), 1.0)
            px, py = ax + t * vx, ay + t * vy
            dist2 = (x_m - px) ** 2 + (y_m - py) ** 2
            if best is None or dist2 < best[0]:
                seg = math.sqrt(seg2)
                side = vx * (y_m - ay) - vy * (x_m - ax)
                d = math.copysign(math.sqrt(dist2), side) if seg > 0 else math.sqrt(dist2)
                best = (dist2, self._s[a] + t * (self._s[b] - self._s[a]), d)
        if best is None:  # open frame, single segment edge case
            return float(self._s[i]), float(math.hypot(x_m - self._x[i], y_m - self._y[i]))
        return float(self._wrap_s(best[1])), float(best[2])

    def project_many(self, xy_m: ArrayLike) -> tuple[FloatArray, FloatArray]:
        """Frenet (s, d) of many points (N, 2) at once, each onto its nearest part of the frame
        (no branch hint: for a frame that does not cross itself). d > 0 left of the frame."""
        pts = np.asarray(xy_m, np.float64).reshape(-1, 2)
        if len(pts) == 0:
            return np.zeros(0), np.zeros(0)
        _, idx = self._tree.query(pts)
        idx = np.asarray(idx, np.int64)
        best_s = np.zeros(len(pts))
        best_d = np.zeros(len(pts))
        best_d2 = np.full(len(pts), np.inf)
        for shift in (-1, 0):
            a = idx + shift
            b = a + 1
            if self.closed:
                a = np.mod(a, self._m)
                b = np.where(np.mod(b, self._m) == 0, self._m, np.mod(b, self._m))
                valid = np.ones(len(pts), bool)
            else:
                valid = (a >= 0) & (b <= self._m - 1)
                a = np.clip(a, 0, self._m - 1)
                b = np.clip(b, 0, self._m - 1)
            ax, ay, bx, by = self._x[a], self._y[a], self._x[b], self._y[b]
            vx, vy = bx - ax, by - ay
            seg2 = np.maximum(vx * vx + vy * vy, 1e-18)
            t = np.clip(((pts[:, 0] - ax) * vx + (pts[:, 1] - ay) * vy) / seg2, 0.0, 1.0)
            px, py = ax + t * vx, ay + t * vy
            dist2 = (pts[:, 0] - px) ** 2 + (pts[:, 1] - py) ** 2
            side = vx * (pts[:, 1] - ay) - vy * (pts[:, 0] - ax)
            better = valid & (dist2 < best_d2)
            best_d2 = np.where(better, dist2, best_d2)
            best_s = np.where(better, self._s[a] + t * (self._s[b] - self._s[a]), best_s)
            best_d = np.where(better, np.copysign(np.sqrt(dist2), side), best_d)
        return self._wrap_s(best_s), best_d

    def distance_m(self, x_m: float, y_m: float) -> float:
        """Distance from the baseframe (m), to the nearest sample."""
        dist, _ = self._tree.query([x_m, y_m])
        return float(dist)

    def to_message(self) -> Baseframe:
        """The samples as a :class:`common.messages.Baseframe`."""
        return Baseframe(
            s_m=self.s_m.copy(),
            x_m=self._x[: self._m].copy(),
            y_m=self._y[: self._m].copy(),
            heading_rad=self.heading_rad,
            curvature_1pm=self.curvature_1pm.copy(),
            closed=self.closed,
            length_m=self.length_m,
        )


def centre_on_cones(
    frame: SplineBaseframe,
    cones_xy_m: ArrayLike,
    colours: ArrayLike,
    *,
    max_shift_m: float = 2.0,
    max_lateral_m: float = 6.0,
    smoothing_m: float = 3.0,
    resample_m: float = 1.0,
    step_m: float = 0.25,
) -> SplineBaseframe:
    """Shift a baseframe to the middle between blue (left) and yellow (right) cones.

    The cones are projected onto the frame; the left and right boundary offsets are interpolated
    along s and the frame is moved by their mean (clipped to ``max_shift_m``) and refitted. Where
    one side is missing the frame is left where it was. Returns the frame unchanged when there are
    too few cones of either colour.
    """
    xy = np.asarray(cones_xy_m, np.float64).reshape(-1, 2)
    col = np.asarray(colours, np.int64).reshape(-1)
    sides = []
    for colour, sign in ((ConeColour.BLUE, 1.0), (ConeColour.YELLOW, -1.0)):
        pts = xy[col == int(colour)]
        sd = np.array([frame.project(float(p[0]), float(p[1])) for p in pts]).reshape(-1, 2)
        # keep cones on the expected side, near the frame
        ok = (sd[:, 1] * sign > 0.3) & (np.abs(sd[:, 1]) < max_lateral_m)
        sides.append(sd[ok])
    if min(len(s) for s in sides) < 4:
        return frame
    s = frame.s_m
    offsets = []
    for sd in sides:
        order = np.argsort(sd[:, 0])
        ss, dd = sd[order, 0], sd[order, 1]
        if frame.closed:
            offsets.append(np.interp(s, ss, dd, period=frame.length_m))
        else:
            offsets.append(np.interp(s, ss, dd))
    centre = 0.5 * (offsets[0] + offsets[1])
    centre = np.clip(centre, -max_shift_m, max_shift_m)
    shifted = frame.frenet_to_xy(s, centre)
    if not frame.closed:
        shifted = np.vstack([shifted, frame.frenet_to_xy(frame.length_m, centre[-1:])])
    return SplineBaseframe(
        shifted, frame.closed, resample_m=resample_m, smoothing_m=smoothing_m, step_m=step_m
    )
