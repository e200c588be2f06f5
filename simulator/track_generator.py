"""Built-in layouts: seeded random trackdrive tracks, the default track, and a rule checker.

A generated track follows the Formula Student trackdrive rules (checked by
:func:`check_fs_rules`): track at least 3 m wide, cones at most 5 m apart along a side,
straights at most 80 m, hairpins at least 9 m outer diameter, a lap of 200-500 m, big orange
cones at the start/finish line. Blue cones on the left, yellow on the right, small cones
(228 mm base), the car staged 8 m (rear axle) before the start line.

The centreline is a periodic cubic spline through control points on a star-shaped polygon
(so it never crosses itself), rejected and redrawn until it meets the rules.
"""

from __future__ import annotations

import functools
import math

import numpy as np
from scipy.interpolate import CubicSpline

from common.errors import TrackError
from common.messages import ConeColour, ConeSize
from common.polyline import (
    FloatArray,
    nearest_on_polyline,
    polyline_curvature,
    polyline_length,
    resample,
    smooth_closed,
)
from simulator.track import Track
from simulator.track_layouts import RawLayout, finish_track, line_from_cluster

MIN_WIDTH_M = 3.0
MAX_CONE_SPACING_M = 5.0
MAX_STRAIGHT_M = 80.0
MIN_HAIRPIN_OUTER_DIAMETER_M = 9.0
MIN_LAP_M = 200.0
MAX_LAP_M = 500.0
STRAIGHT_CURVATURE_1PM = 1.0 / 50.0
"""A stretch of centreline whose curvature stays below this (radius above 50 m) is a straight."""
START_OFFSET_M = 8.0
"""The car's rear axle is staged this far before the start line."""
MIN_CENTRE_RADIUS_M = 5.0
"""The generator's tightest centreline radius (the default car turns on 2.7 m at the rear axle;
the hairpin outer diameter is then at least 2 * (5 + 1.75) = 13.5 m)."""


# ---------------------------------------------------------------------------------------------
# Rule checks
# ---------------------------------------------------------------------------------------------


def _smooth_periodic(values: FloatArray, window: int) -> FloatArray:
    if window <= 1 or len(values) < window:
        return values
    half = window // 2
    padded = np.concatenate([values[-half:], values, values[:half]])
    return np.convolve(padded, np.ones(window) / window, mode="valid")


def longest_straight_m(track: Track) -> float:
    """Longest stretch (m) of the centreline with radius above 50 m (smoothed over ~3 m)."""
    c = track.centreline_xy_m
    step = track.lap_length_m / len(c) if track.is_loop else polyline_length(c, False) / len(c)
    k = polyline_curvature(c, track.is_loop)
    k = _smooth_periodic(k, max(int(3.0 / max(step, 1e-3)) | 1, 1))
    straight = np.abs(k) < STRAIGHT_CURVATURE_1PM
    if straight.all():
        return float(track.lap_length_m)
    if not straight.any():
        return 0.0
    if track.is_loop:  # rotate so the sequence starts on a corner sample
        straight = np.roll(straight, -int(np.argmin(straight)))
    padded = np.concatenate([[False], straight, [False]]).astype(np.int8)
    edges = np.diff(padded)
    starts = np.nonzero(edges == 1)[0]
    ends = np.nonzero(edges == -1)[0]
    return float((ends - starts).max() * step)


def min_hairpin_outer_diameter_m(track: Track) -> float:
    """Smallest outer diameter (m) of any bend: 2 * (centreline radius + outer half width)."""
    c = track.centreline_xy_m
    step = track.lap_length_m / len(c)
    k = polyline_curvature(c, track.is_loop)
    k = _smooth_periodic(k, max(int(2.0 / max(step, 1e-3)) | 1, 1))
    outer_half = np.where(k > 0.0, track.right_half_width_m, track.left_half_width_m)
    with np.errstate(divide="ignore"):
        diameter = 2.0 * (1.0 / np.abs(k) + outer_half)
    return float(diameter.min())


def _side_spacing_max_m(side_xy: FloatArray, closed: bool) -> float:
    if len(side_xy) < 2:
        return math.inf
    d = np.hypot(*np.diff(side_xy, axis=0).T)
    if closed:
        d = np.append(d, math.hypot(*(side_xy[0] - side_xy[-1])))
    return float(d.max())


def _min_width_m(track: Track) -> float:
    """Smallest cone-to-opposite-boundary distance (m) over both sides."""
    l, r = track.left_xy_m, track.right_xy_m
    if len(l) < 2 or len(r) < 2:
        return 0.0
    d1 = nearest_on_polyline(l, r, track.is_loop)[0]
    d2 = nearest_on_polyline(r, l, track.is_loop)[0]
    return float(min(d1.min(), d2.min()))


def check_fs_rules(track: Track) -> list[str]:
    """The Formula Student trackdrive rules a layout breaks (empty when it follows them all).

    Checks: width >= 3 m (each boundary cone to the opposite boundary), cones <= 5 m apart
    along each side, straights <= 80 m, hairpin outer diameter >= 9 m, lap 200-500 m (loops
    only), big orange cones at the start/finish. Tolerances are 1 mm.
    """
    problems: list[str] = []
    tol = 1e-3
    width = _min_width_m(track)
    if width < MIN_WIDTH_M - tol:
        problems.append(f"track narrower than {MIN_WIDTH_M} m: {width:.2f} m")
    for name, side in (("left", track.left_xy_m), ("right", track.right_xy_m)):
        gap = _side_spacing_max_m(side, track.is_loop)
        if gap > MAX_CONE_SPACING_M + tol:
            problems.append(f"{name} cones {gap:.2f} m apart (max {MAX_CONE_SPACING_M} m)")
    straight = longest_straight_m(track)
    if straight > MAX_STRAIGHT_M + tol:
        problems.append(f"straight of {straight:.1f} m (max {MAX_STRAIGHT_M} m)")
    hairpin = min_hairpin_outer_diameter_m(track)
    if hairpin < MIN_HAIRPIN_OUTER_DIAMETER_M - tol:
        problems.append(f"hairpin outer diameter {hairpin:.2f} m (min"
                        f" {MIN_HAIRPIN_OUTER_DIAMETER_M} m)")
    if track.is_loop and not MIN_LAP_M - tol <= track.lap_length_m <= MAX_LAP_M + tol:
        problems.append(f"lap {track.lap_length_m:.1f} m outside {MIN_LAP_M}-{MAX_LAP_M} m")
    n_big = int(np.sum(track.colours == ConeColour.BIG_ORANGE))
    if n_big < 2 or not np.all(np.isfinite(track.start_line_xy_m)):
        problems.append(f"no start/finish line of big orange cones ({n_big} big orange)")
    return problems


# ---------------------------------------------------------------------------------------------
# Building a track from a centreline
# ---------------------------------------------------------------------------------------------


def _periodic_spline(ctrl: FloatArray, step_m: float) -> FloatArray:
    """Sample a periodic cubic spline through control points (K,2) every ~``step_m``."""
    pts = np.vstack([ctrl, ctrl[:1]])
    chord = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(pts, axis=0).T))])
    spline = CubicSpline(chord, pts, bc_type="periodic")
    fine = spline(np.linspace(0.0, chord[-1], int(chord[-1] / (0.2 * step_m)) + 8,
                              endpoint=False))
    return resample(fine, step_m, True)


def _normals(centre: FloatArray) -> FloatArray:
    t = np.roll(centre, -1, axis=0) - np.roll(centre, 1, axis=0)
    t /= np.maximum(np.hypot(t[:, 0], t[:, 1]), 1e-9)[:, None]
    return np.stack([-t[:, 1], t[:, 0]], axis=1)


def _place_side(boundary: FloatArray, curvature: FloatArray, start_index: int,
                max_spacing_m: float) -> tuple[FloatArray, FloatArray]:
    """Cones along a closed boundary polyline, the first at ``start_index``; spacing from about
    2 m in tight bends to ``max_spacing_m`` on straights. Returns (cones (K,2), their arc
    position from the start (K,))."""
    b = np.roll(boundary, -start_index, axis=0)
    k = np.abs(np.roll(curvature, -start_index))
    pts = np.vstack([b, b[:1]])
    seg = np.hypot(*np.diff(pts, axis=0).T)
    s = np.concatenate([[0.0], np.cumsum(seg)])
    with np.errstate(divide="ignore"):
        radius = np.where(k > 1e-6, 1.0 / k, 1e6)
    spacing = np.clip(1.1 * np.sqrt(radius), 2.0, max_spacing_m)
    density = np.concatenate([[1.0 / spacing[0]], 1.0 / spacing])
    cum = np.concatenate([[0.0], np.cumsum(0.5 * (density[1:] + density[:-1]) * np.diff(s))])
    n = max(int(math.ceil(cum[-1])), 3)
    targets = np.arange(n) * (cum[-1] / n)
    at = np.interp(targets, cum, s)
    cones = np.stack([np.interp(at, s, pts[:, 0]), np.interp(at, s, pts[:, 1])], axis=1)
    return cones, at


def track_from_centreline(name: str, centre: FloatArray, width_m: float,
                          start_index: int = 0) -> Track:
    """A trackdrive :class:`Track` from a closed centreline (M,2) sampled every ~0.5 m.

    Cones go on both sides ``width_m / 2`` from the centreline (blue left, yellow right) with
    the start/finish line (4 big orange cones, 0.5 m either side of it) at sample
    ``start_index``; the car is staged :data:`START_OFFSET_M` before the line.
    """
    n_pts = len(centre)
    normal = _normals(centre)
    half = 0.5 * width_m
    kappa = polyline_curvature(centre, True)
    left_b = centre + half * normal
    right_b = centre - half * normal
    kl = kappa / np.maximum(1.0 - half * kappa, 0.2)
    kr = kappa / np.maximum(1.0 + half * kappa, 0.2)
    max_gap = MAX_CONE_SPACING_M - 0.6
    left, _ = _place_side(left_b, kl, start_index, max_gap)
    right, _ = _place_side(right_b, kr, start_index, max_gap)
    # the first cone of each side sits on the start line: replace it by two big orange cones
    step = polyline_length(centre, True) / n_pts
    off = max(int(round(0.5 / step)), 1)
    ia, ib = (start_index - off) % n_pts, (start_index + off) % n_pts
    big = np.array([left_b[ia], left_b[ib], right_b[ia], right_b[ib]])
    left, right = left[1:], right[1:]
    left_side = np.vstack([big[1:2], left, big[0:1]])
    right_side = np.vstack([big[3:4], right, big[2:3]])
    xy = np.vstack([left, right, big])
    colours = np.array([ConeColour.BLUE] * len(left) + [ConeColour.YELLOW] * len(right)
                       + [ConeColour.BIG_ORANGE] * 4, np.int64)
    sizes = np.array([ConeSize.SMALL] * (len(left) + len(right)) + [ConeSize.LARGE] * 4,
                     np.int64)
    back = int(round(START_OFFSET_M / step))
    j = (start_index - back) % n_pts
    t = centre[(j + 1) % n_pts] - centre[j - 1]
    pose = (float(centre[j, 0]), float(centre[j, 1]), math.atan2(float(t[1]), float(t[0])))
    tl = centre[(start_index + 1) % n_pts] - centre[start_index - 1]
    start_line = line_from_cluster(big, math.atan2(float(tl[1]), float(tl[0])))
    raw = RawLayout(name, name, xy, colours, sizes, pose)
    return finish_track(raw, "trackdrive", pose, centre, left_side, right_side, True, start_line,
                   start_line)


def _self_clearance_ok(centre: FloatArray, width_m: float) -> bool:
    """Parts of the loop further apart along it than 4 track widths keep 2 widths + 2 m apart."""
    c = centre[::2]
    n = len(c)
    step = polyline_length(centre, True) / n
    d = np.hypot(c[:, None, 0] - c[None, :, 0], c[:, None, 1] - c[None, :, 1])
    idx = np.arange(n)
    sep = np.abs(idx[:, None] - idx[None, :])
    sep = np.minimum(sep, n - sep) * step
    far = sep > 4.0 * width_m + 6.0
    return bool(d[far].min() >= 2.0 * width_m + 2.0) if far.any() else True


def _straightest_index(centre: FloatArray) -> int:
    k = np.abs(polyline_curvature(centre, True))
    return int(np.argmin(_smooth_periodic(k, 41)))


@functools.lru_cache(maxsize=64)
def generate_track(seed: int, width_m: float | None = None) -> Track:
    """A random, rule-abiding trackdrive layout for ``seed`` (same seed, same track).

    Raises :class:`TrackError` if no layout passes the rules in 200 draws (not seen in
    practice). Cached: treat the returned Track as read-only.
    """
    rng = np.random.default_rng(seed)
    for _attempt in range(200):
        w = float(width_m) if width_m is not None else float(rng.uniform(3.5, 4.5))
        n_ctrl = int(rng.integers(7, 12))
        base = np.linspace(0.0, 2.0 * math.pi, n_ctrl, endpoint=False)
        ang = base + rng.uniform(-0.35, 0.35, n_ctrl) * (2.0 * math.pi / n_ctrl)
        radius = np.exp(rng.normal(0.0, 0.45, n_ctrl))
        stretch = rng.uniform(1.0, 1.8)
        ctrl = np.stack([stretch * radius * np.cos(ang), radius * np.sin(ang)], axis=1)
        if rng.random() < 0.5:  # clockwise or counter-clockwise
            ctrl[:, 1] = -ctrl[:, 1]
        target = float(rng.uniform(250.0, 450.0))
        centre = _periodic_spline(ctrl, 0.5)
        centre = _periodic_spline(ctrl * (target / polyline_length(centre, True)), 0.5)
        for _ in range(2):
            centre = smooth_closed(centre, 15)
        centre = resample(centre * (target / polyline_length(centre, True)), 0.5, True)
        kappa = polyline_curvature(centre, True)
        if np.abs(kappa).max() > 1.0 / MIN_CENTRE_RADIUS_M:
            continue
        if not _self_clearance_ok(centre, w):
            continue
        track = track_from_centreline(f"gen:{seed}", centre, w, _straightest_index(centre))
        if not check_fs_rules(track):
            return track
    raise TrackError(f"gen:{seed}: no rule-abiding layout found in 200 draws")


# Control points of the default track (m): a ~300 m lap with a long start straight, a fast
# sweeper, a hairpin, a chicane and a few medium bends.
_DEFAULT_CONTROL_POINTS_M = np.array([
    [0.0, 0.0], [25.0, 0.0], [45.0, 1.0], [58.0, 8.0], [62.0, 20.0], [55.0, 30.0],
    [44.0, 31.0], [36.0, 24.0], [26.0, 22.0], [18.0, 30.0], [20.0, 42.0], [12.0, 50.0],
    [0.0, 48.0], [-6.0, 38.0], [-14.0, 30.0], [-24.0, 26.0], [-30.0, 16.0], [-26.0, 5.0],
    [-14.0, 0.5],
])
DEFAULT_WIDTH_M = 3.75
_DEFAULT_SCALE = 1.15


@functools.lru_cache(maxsize=1)
def default_track() -> Track:
    """The built-in track that ``python main.py`` drives (cached: treat as read-only)."""
    centre = _periodic_spline(_DEFAULT_CONTROL_POINTS_M * _DEFAULT_SCALE, 0.5)
    start = int(np.argmin(np.hypot(centre[:, 0] - 10.0, centre[:, 1])))
    track = track_from_centreline("default", centre, DEFAULT_WIDTH_M, start)
    problems = check_fs_rules(track)
    if problems:  # a programming error, caught by the tests
        raise TrackError(f"default track breaks the rules: {'; '.join(problems)}")
    return track
