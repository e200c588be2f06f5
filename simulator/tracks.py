"""Tracks: cone layouts, their centreline and boundaries, in the world frame.

Loads the community formats (EUFS CSV ``tag,x,y,direction,x_variance,y_variance,xy_covariance``
and AMZ FSSIM YAML ``cones_left`` / ``cones_right`` / ``cones_orange`` / ``cones_orange_big`` /
``starting_pose_front_wing``), the built-in default track and generated trackdrive layouts
(``"gen:SEED"``). Everything is moved into the WORLD frame: the car's start pose (the vehicle
origin, the rear-axle centre) is (0, 0) with yaw 0.

Three kinds of layout are understood:
- ``trackdrive``: a closed loop, blue cones on the left, yellow on the right; the centreline is
  built from midpoints between the two ordered boundaries and is a closed loop (``is_loop``).
- ``acceleration``: a straight; the centreline runs from the car's start to the last cone.
- ``skidpad``: the figure of eight; the centreline is the driven path (entry, two right laps,
  two left laps, exit), not a loop.

Real files vary: repeated header rows, no start pose, unordered cones. Missing start poses are
inferred from the big orange cones (the car is put on the centreline 6 m before the start line);
anything that cannot be understood raises :class:`common.errors.TrackError` naming the file and
what is wrong.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import yaml
from numpy.typing import NDArray

from common.conventions import wrap_angle, wrap_angles
from common.errors import TrackError
from common.messages import ConeColour, ConeSize

log = logging.getLogger(__name__)

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

SMALL_CONE_RADIUS_M = 0.228 / 2.0
"""Base radius of a small cone (228 mm base)."""
LARGE_CONE_RADIUS_M = 0.285 / 2.0
"""Base radius of a large cone (285 mm base)."""
FRONT_WING_TO_ORIGIN_M = 2.25
"""Distance from the front of the default car back to the vehicle origin (rear axle), used to
turn FSSIM's ``starting_pose_front_wing`` into the start pose (length 2.9 - rear overhang 0.65)."""
START_BEHIND_LINE_M = 6.0
"""Where a car is put when the file has no start pose: this far before the start line."""
CENTRELINE_STEP_M = 0.5
"""Spacing of the centreline samples (m)."""

_EUFS_TAGS: dict[str, tuple[ConeColour, ConeSize]] = {
    "blue": (ConeColour.BLUE, ConeSize.SMALL),
    "yellow": (ConeColour.YELLOW, ConeSize.SMALL),
    "orange": (ConeColour.ORANGE, ConeSize.SMALL),
    "small_orange": (ConeColour.ORANGE, ConeSize.SMALL),
    "big_orange": (ConeColour.BIG_ORANGE, ConeSize.LARGE),
    "large_orange": (ConeColour.BIG_ORANGE, ConeSize.LARGE),
    "unknown": (ConeColour.UNKNOWN, ConeSize.SMALL),
}
_EUFS_NON_CONE_TAGS = {"car_start", "midpoint"}


# ---------------------------------------------------------------------------------------------
# Polyline helpers (vectorised)
# ---------------------------------------------------------------------------------------------


def _segments(poly: FloatArray, closed: bool) -> tuple[FloatArray, FloatArray]:
    """Segment start points (K,2) and vectors (K,2) of a polyline."""
    if closed:
        return poly, np.roll(poly, -1, axis=0) - poly
    return poly[:-1], poly[1:] - poly[:-1]


def nearest_on_polyline(
    points_xy: FloatArray, poly_xy: FloatArray, closed: bool
) -> tuple[FloatArray, IntArray, FloatArray, FloatArray]:
    """Nearest point on a polyline for each of ``points_xy`` (P,2).

    Returns ``(distance_m (P,), segment_index (P,), t (P,) in [0,1] along that segment,
    projection_xy (P,2))``.
    """
    a, ab = _segments(poly_xy, closed)
    p = np.asarray(points_xy, np.float64).reshape(-1, 2)
    ab2 = np.maximum((ab * ab).sum(axis=1), 1e-12)
    rel_x = p[:, None, 0] - a[None, :, 0]
    rel_y = p[:, None, 1] - a[None, :, 1]
    t = np.clip((rel_x * ab[None, :, 0] + rel_y * ab[None, :, 1]) / ab2[None, :], 0.0, 1.0)
    dx = rel_x - t * ab[None, :, 0]
    dy = rel_y - t * ab[None, :, 1]
    d2 = dx * dx + dy * dy
    idx = np.argmin(d2, axis=1)
    rows = np.arange(p.shape[0])
    tt = t[rows, idx]
    proj = a[idx] + tt[:, None] * ab[idx]
    return np.sqrt(d2[rows, idx]), idx.astype(np.int64), tt, proj


def arc_lengths(poly_xy: FloatArray, closed: bool) -> FloatArray:
    """Cumulative arc length at each vertex (K,), starting at 0; for a closed polyline the
    total length is ``arc[-1] + |last - first|``."""
    d = np.hypot(*np.diff(poly_xy, axis=0).T)
    return np.concatenate([[0.0], np.cumsum(d)])


def polyline_length(poly_xy: FloatArray, closed: bool) -> float:
    """Total length (m) of a polyline (closing segment included when ``closed``)."""
    d = float(np.hypot(*np.diff(poly_xy, axis=0).T).sum())
    if closed and len(poly_xy) > 1:
        d += float(np.hypot(*(poly_xy[0] - poly_xy[-1])))
    return d


def resample(poly_xy: FloatArray, step_m: float, closed: bool) -> FloatArray:
    """Resample a polyline at (about) equal arc-length steps; closed ones stay implicitly closed."""
    pts = np.vstack([poly_xy, poly_xy[:1]]) if closed else poly_xy
    s = arc_lengths(pts, False)
    total = float(s[-1])
    if total <= 0.0:
        return poly_xy.copy()
    n = max(int(round(total / step_m)), 2)
    if closed:
        q = np.linspace(0.0, total, n, endpoint=False)
    else:
        q = np.linspace(0.0, total, n + 1)
    return np.stack([np.interp(q, s, pts[:, 0]), np.interp(q, s, pts[:, 1])], axis=1)


def smooth_closed(poly_xy: FloatArray, window: int) -> FloatArray:
    """Periodic moving average with an odd ``window`` (samples)."""
    if window <= 1 or len(poly_xy) < window:
        return poly_xy.copy()
    half = window // 2
    padded = np.vstack([poly_xy[-half:], poly_xy, poly_xy[:half]])
    kernel = np.ones(window) / window
    return np.stack([np.convolve(padded[:, k], kernel, mode="valid") for k in (0, 1)], axis=1)


def polyline_curvature(poly_xy: FloatArray, closed: bool) -> FloatArray:
    """Signed curvature (1/m, positive turning left) at each vertex (K,) from heading changes."""
    pts = np.vstack([poly_xy[-1:], poly_xy, poly_xy[:1]]) if closed else poly_xy
    seg = np.diff(pts, axis=0)
    heading = np.arctan2(seg[:, 1], seg[:, 0])
    length = np.hypot(seg[:, 0], seg[:, 1])
    dh = wrap_angles(np.diff(heading))
    ds = 0.5 * (length[1:] + length[:-1])
    k = dh / np.maximum(ds, 1e-9)
    if closed:
        return k
    return np.concatenate([[k[0] if len(k) else 0.0], k, [k[-1] if len(k) else 0.0]])


def _transform(xy: FloatArray, pose: tuple[float, float, float]) -> FloatArray:
    """Points (N,2) of the file frame into the frame of ``pose`` (x, y, yaw) in that file frame."""
    x0, y0, yaw0 = pose
    c, s = math.cos(yaw0), math.sin(yaw0)
    d = np.asarray(xy, np.float64).reshape(-1, 2) - np.array([x0, y0])
    return np.stack([d[:, 0] * c + d[:, 1] * s, -d[:, 0] * s + d[:, 1] * c], axis=1)


# ---------------------------------------------------------------------------------------------
# The Track
# ---------------------------------------------------------------------------------------------


@dataclass(eq=False)
class Track:
    """A cone layout in the world frame (the car starts at (0, 0) facing +x).

    ``cones_xy_m`` (N,2), ``colours`` (N,) :class:`ConeColour` ints, ``sizes`` (N,)
    :class:`ConeSize` ints. ``centreline_xy_m`` (M,2) sampled every ~0.5 m starting at the sample
    nearest the start; for a loop the last sample connects back to the first (it is not
    repeated). ``left_xy_m`` / ``right_xy_m`` (K,2) are the boundary cones ordered along the
    centreline. ``width_m`` is the median track width, ``lap_length_m`` the centreline length.
    ``start_line_xy_m`` (2,2) the ends of the start/finish line (NaN when unknown);
    ``finish_line_xy_m`` differs from it only for acceleration.
    """

    name: str
    cones_xy_m: FloatArray
    colours: IntArray
    sizes: IntArray
    centreline_xy_m: FloatArray
    left_xy_m: FloatArray
    right_xy_m: FloatArray
    width_m: float
    is_loop: bool
    lap_length_m: float
    kind: str = "trackdrive"
    start_line_xy_m: FloatArray = field(default_factory=lambda: np.full((2, 2), np.nan))
    finish_line_xy_m: FloatArray = field(default_factory=lambda: np.full((2, 2), np.nan))
    source: str = ""

    # derived (filled in __post_init__)
    centreline_s_m: FloatArray = field(init=False, repr=False)
    left_half_width_m: FloatArray = field(init=False, repr=False)
    right_half_width_m: FloatArray = field(init=False, repr=False)
    cone_radius_m: FloatArray = field(init=False, repr=False)
    _seg_a: FloatArray = field(init=False, repr=False)
    _seg_ab: FloatArray = field(init=False, repr=False)
    _seg_len: FloatArray = field(init=False, repr=False)
    _grid: dict[tuple[int, int], list[int]] = field(init=False, repr=False)
    _grid_cell_m: float = field(init=False, repr=False, default=4.0)
    _seg_list: list[tuple[float, float, float, float, float]] = field(init=False, repr=False)
    _s_list: list[float] = field(init=False, repr=False)
    _len_list: list[float] = field(init=False, repr=False)
    _cone_list: list[tuple[float, float, float]] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        self.cones_xy_m = np.asarray(self.cones_xy_m, np.float64).reshape(-1, 2)
        self.colours = np.asarray(self.colours, np.int64)
        self.sizes = np.asarray(self.sizes, np.int64)
        self.centreline_xy_m = np.asarray(self.centreline_xy_m, np.float64).reshape(-1, 2)
        self.left_xy_m = np.asarray(self.left_xy_m, np.float64).reshape(-1, 2)
        self.right_xy_m = np.asarray(self.right_xy_m, np.float64).reshape(-1, 2)
        n = len(self.cones_xy_m)
        if self.colours.shape != (n,) or self.sizes.shape != (n,):
            raise TrackError(f"track {self.name!r}: colours/sizes do not match {n} cones")
        if len(self.centreline_xy_m) < 2:
            raise TrackError(f"track {self.name!r}: centreline has fewer than 2 points")
        c = self.centreline_xy_m
        self._seg_a, self._seg_ab = _segments(c, self.is_loop)
        self._seg_len = np.hypot(self._seg_ab[:, 0], self._seg_ab[:, 1])
        self.centreline_s_m = np.concatenate([[0.0], np.cumsum(self._seg_len)])[: len(c)]
        self._seg_list = [(float(a[0]), float(a[1]), float(b[0]), float(b[1]),
                           max(float(b[0] * b[0] + b[1] * b[1]), 1e-12))
                          for a, b in zip(self._seg_a, self._seg_ab, strict=True)]
        self._s_list = self.centreline_s_m.tolist()
        self._len_list = self._seg_len.tolist()
        self.cone_radius_m = np.where(self.sizes == ConeSize.LARGE, LARGE_CONE_RADIUS_M,
                                      SMALL_CONE_RADIUS_M)
        self._half_widths()
        self._build_grid()

    # -- derived data -------------------------------------------------------------------------

    def _half_widths(self) -> None:
        c = self.centreline_xy_m
        big = 50.0
        if self.kind == "skidpad":
            # The path crosses itself: widths from the nearest boundary cone on each side.
            self.left_half_width_m = np.full(len(c), 1.5)
            self.right_half_width_m = np.full(len(c), 1.5)
            if len(self.left_xy_m) and len(self.right_xy_m):
                dl = np.min(np.hypot(*(c[:, None, :] - self.left_xy_m[None]).transpose(2, 0, 1)),
                            axis=1)
                dr = np.min(np.hypot(*(c[:, None, :] - self.right_xy_m[None]).transpose(2, 0, 1)),
                            axis=1)
                both = np.minimum(dl, dr)
                self.left_half_width_m = both.copy()
                self.right_half_width_m = both.copy()
            return
        if len(self.left_xy_m) >= 2:
            self.left_half_width_m = nearest_on_polyline(c, self.left_xy_m, self.is_loop)[0]
        else:
            self.left_half_width_m = np.full(len(c), big)
        if len(self.right_xy_m) >= 2:
            self.right_half_width_m = nearest_on_polyline(c, self.right_xy_m, self.is_loop)[0]
        else:
            self.right_half_width_m = np.full(len(c), big)

    def _build_grid(self) -> None:
        cell = self._grid_cell_m
        self._grid = {}
        self._cone_list = []
        for i, ((x, y), r) in enumerate(zip(self.cones_xy_m.tolist(),
                                            self.cone_radius_m.tolist(), strict=True)):
            self._grid.setdefault((math.floor(x / cell), math.floor(y / cell)), []).append(i)
            self._cone_list.append((x, y, r))

    @property
    def widths_m(self) -> FloatArray:
        """Track width at each centreline sample (M,), from the boundary polylines (m)."""
        return self.left_half_width_m + self.right_half_width_m

    @property
    def start_line_s_m(self) -> float:
        """Progress (m) of the start line's centre; NaN when there is no start line."""
        if not np.all(np.isfinite(self.start_line_xy_m)):
            return math.nan
        mid = self.start_line_xy_m.mean(axis=0)
        return self.progress_m(float(mid[0]), float(mid[1]))

    # -- queries ------------------------------------------------------------------------------

    def locate(
        self, x_m: float, y_m: float, hint: int | None = None, window: int = 40
    ) -> tuple[float, float, int]:
        """Project a point onto the centreline.

        Returns ``(progress_m, lateral_m, segment_index)``: arc length from the first sample,
        signed lateral offset (positive left of the driving direction) and the segment. With a
        ``hint`` (a previous segment index) the search walks from there to the nearest segment
        within ``window`` segments either side, which is fast and follows self-crossing paths
        (skidpad) correctly.
        """
        if hint is not None:
            found = self._locate_local(x_m, y_m, hint, window)
            if found is not None:
                return found
        return self._locate_global(x_m, y_m, hint, window)

    def _seg_distance2(self, x: float, y: float, k: int) -> float:
        ax, ay, abx, aby, ab2 = self._seg_list[k]
        t = ((x - ax) * abx + (y - ay) * aby) / ab2
        t = 0.0 if t < 0.0 else (1.0 if t > 1.0 else t)
        dx = x - ax - t * abx
        dy = y - ay - t * aby
        return dx * dx + dy * dy

    def _locate_local(self, x: float, y: float, hint: int,
                      window: int) -> tuple[float, float, int] | None:
        """Walk from segment ``hint`` downhill in distance (pure Python, a few segments)."""
        n = len(self._seg_list)
        loop = self.is_loop
        if not 0 <= hint < n:
            return None
        best = hint
        best_d2 = self._seg_distance2(x, y, hint)
        for direction in (1, -1):
            k = hint
            misses = 0
            for _ in range(window):
                k += direction
                if loop:
                    k %= n
                elif not 0 <= k < n:
                    break
                d2 = self._seg_distance2(x, y, k)
                if d2 < best_d2:
                    best, best_d2 = k, d2
                    misses = 0
                else:
                    misses += 1
                    if misses > 3:
                        break
        ax, ay, abx, aby, ab2 = self._seg_list[best]
        t = ((x - ax) * abx + (y - ay) * aby) / ab2
        t = 0.0 if t < 0.0 else (1.0 if t > 1.0 else t)
        px, py = x - ax, y - ay
        s = self._s_list[best] + t * self._len_list[best]
        cross = abx * py - aby * px
        lateral = math.sqrt(best_d2) * (1.0 if cross >= 0.0 else -1.0)
        return s, lateral, best

    def _locate_global(
        self, x_m: float, y_m: float, hint: int | None, window: int
    ) -> tuple[float, float, int]:
        a, ab = self._seg_a, self._seg_ab
        k = len(a)
        if hint is not None and 2 * window + 1 < k:
            if self.is_loop:
                idx = np.arange(hint - window, hint + window + 1) % k
            else:
                idx = np.arange(max(hint - window, 0), min(hint + window + 1, k))
            a = a[idx]
            ab = ab[idx]
        else:
            idx = None
        px = x_m - a[:, 0]
        py = y_m - a[:, 1]
        ab2 = np.maximum(ab[:, 0] * ab[:, 0] + ab[:, 1] * ab[:, 1], 1e-12)
        t = np.clip((px * ab[:, 0] + py * ab[:, 1]) / ab2, 0.0, 1.0)
        dx = px - t * ab[:, 0]
        dy = py - t * ab[:, 1]
        j = int(np.argmin(dx * dx + dy * dy))
        seg = int(idx[j]) if idx is not None else j
        tj = float(t[j])
        s = float(self.centreline_s_m[seg] + tj * self._seg_len[seg])
        abx, aby = float(ab[j, 0]), float(ab[j, 1])
        cross = abx * float(py[j]) - aby * float(px[j])
        lateral = math.hypot(float(dx[j]), float(dy[j])) * (1.0 if cross >= 0.0 else -1.0)
        return s, lateral, seg

    def progress_m(self, x_m: float, y_m: float) -> float:
        """Arc length (m) along the centreline of the point nearest to (x, y)."""
        return self.locate(x_m, y_m)[0]

    def point_at(self, s_m: float) -> tuple[float, float, float]:
        """Centreline (x_m, y_m, heading_rad) at progress ``s_m`` (wrapped for loops)."""
        if self.is_loop:
            s_m = s_m % self.lap_length_m
        else:
            s_m = min(max(s_m, 0.0), float(self.centreline_s_m[-1] + self._seg_len[-1]))
        seg = int(np.searchsorted(self.centreline_s_m, s_m, side="right")) - 1
        seg = min(max(seg, 0), len(self._seg_a) - 1)
        t = (s_m - float(self.centreline_s_m[seg])) / max(float(self._seg_len[seg]), 1e-9)
        ax, ay = self._seg_a[seg]
        bx, by = self._seg_ab[seg]
        return float(ax + t * bx), float(ay + t * by), math.atan2(float(by), float(bx))

    def cones_near(self, x_m: float, y_m: float, radius_m: float) -> list[int]:
        """Indices of cones whose grid cell may be within ``radius_m`` of (x, y) (a superset)."""
        cell = self._grid_cell_m
        i0, i1 = math.floor((x_m - radius_m) / cell), math.floor((x_m + radius_m) / cell)
        j0, j1 = math.floor((y_m - radius_m) / cell), math.floor((y_m + radius_m) / cell)
        out: list[int] = []
        for i in range(i0, i1 + 1):
            for j in range(j0, j1 + 1):
                out.extend(self._grid.get((i, j), ()))
        return out

    def cones_touched(self, footprint_xy_m: FloatArray) -> list[int]:
        """Indices of the cones whose base circle overlaps the convex polygon ``footprint``
        (4,2) (corners in order, world frame)."""
        poly = np.asarray(footprint_xy_m, np.float64).reshape(-1, 2).tolist()
        cx = sum(p[0] for p in poly) / len(poly)
        cy = sum(p[1] for p in poly) / len(poly)
        reach = max(math.hypot(p[0] - cx, p[1] - cy) for p in poly) + LARGE_CONE_RADIUS_M
        hits: list[int] = []
        reach2 = reach * reach
        for i in self.cones_near(cx, cy, reach):
            x, y, r = self._cone_list[i]
            if (x - cx) * (x - cx) + (y - cy) * (y - cy) > reach2:
                continue
            if _circle_touches_polygon(x, y, r, poly):
                hits.append(i)
        return sorted(hits)

    def is_off_track(self, footprint_xy_m: FloatArray, hint: int | None = None) -> bool:
        """True when every corner of the footprint (4,2) is beyond a track boundary (the
        Formula Student "off course": all four wheels out). For acceleration and skidpad the
        test uses the distance to the centreline against the local half width."""
        for x, y in np.asarray(footprint_xy_m, np.float64).reshape(-1, 2).tolist():
            _, lateral, seg = self.locate(x, y, hint)
            half = self.left_half_width_m[seg] if lateral >= 0.0 else self.right_half_width_m[seg]
            if abs(lateral) <= half:
                return False
        return True

    def crossed_line(
        self, x0_m: float, y0_m: float, x1_m: float, y1_m: float, finish: bool = False
    ) -> bool:
        """True when the move (x0,y0) -> (x1,y1) crosses the start (or finish) line forwards
        (from the side the car starts on, between the line's ends extended by 1 m)."""
        line = self.finish_line_xy_m if finish else self.start_line_xy_m
        if not np.all(np.isfinite(line)):
            return False
        (ax, ay), (bx, by) = line.tolist()
        # normal of the line, pointing along the driving direction
        dx, dy = bx - ax, by - ay
        length = math.hypot(dx, dy)
        if length <= 0.0:
            return False
        ux, uy = dx / length, dy / length
        mx, my = 0.5 * (ax + bx), 0.5 * (ay + by)
        _, _, heading = self.point_at(self.progress_m(mx, my))
        nx, ny = -uy, ux
        if nx * math.cos(heading) + ny * math.sin(heading) < 0.0:
            nx, ny = -nx, -ny
        d0 = (x0_m - mx) * nx + (y0_m - my) * ny
        d1 = (x1_m - mx) * nx + (y1_m - my) * ny
        if not (d0 < 0.0 <= d1):
            return False
        f = d0 / (d0 - d1)
        cx, cy = x0_m + f * (x1_m - x0_m), y0_m + f * (y1_m - y0_m)
        along = (cx - mx) * ux + (cy - my) * uy
        return abs(along) <= 0.5 * length + 1.0


def _circle_touches_polygon(x: float, y: float, r: float, poly: list[list[float]]) -> bool:
    """Does the circle (x, y, r) overlap the convex polygon (list of [x, y], in order)?"""
    n = len(poly)
    inside_sign = 0
    inside = True
    r2 = r * r
    for k in range(n):
        ax, ay = poly[k]
        bx, by = poly[(k + 1) % n]
        ex, ey = bx - ax, by - ay
        px, py = x - ax, y - ay
        cross = ex * py - ey * px
        sgn = 1 if cross > 0.0 else -1
        if inside_sign == 0:
            inside_sign = sgn
        elif sgn != inside_sign:
            inside = False
        e2 = ex * ex + ey * ey
        t = 0.0 if e2 <= 0.0 else min(max((px * ex + py * ey) / e2, 0.0), 1.0)
        qx, qy = px - t * ex, py - t * ey
        if qx * qx + qy * qy <= r2:
            return True
    return inside


# ---------------------------------------------------------------------------------------------
# Building a Track from cones
# ---------------------------------------------------------------------------------------------


@dataclass
class _RawLayout:
    """Cones as read from a file, in the file's frame."""

    name: str
    source: str
    xy: FloatArray
    colours: IntArray
    sizes: IntArray
    start_pose: tuple[float, float, float] | None  # vehicle origin x, y, yaw in the file frame
    side_hint: IntArray | None = None  # +1 left, -1 right, 0 unknown (FSSIM's explicit sides)


def _order_chain(points: FloatArray, start_xy: FloatArray, start_dir: FloatArray | None,
                 max_gap_m: float = 12.0) -> list[int]:
    """Order cones into a chain: start at the cone nearest ``start_xy``, then repeatedly the
    nearest unvisited cone that is not behind the current direction of travel."""
    n = len(points)
    if n == 0:
        return []
    d0 = np.hypot(*(points - start_xy).T)
    order = [int(np.argmin(d0))]
    visited = np.zeros(n, bool)
    visited[order[0]] = True
    direction = None
    if start_dir is not None:
        direction = start_dir / max(float(np.linalg.norm(start_dir)), 1e-9)
    while not visited.all():
        cur = points[order[-1]]
        rel = points - cur
        dist = np.hypot(rel[:, 0], rel[:, 1])
        cost = dist.copy()
        cost[visited] = np.inf
        if direction is not None:
            cosang = (rel @ direction) / np.maximum(dist, 1e-9)
            cost = np.where(cosang < -0.3, np.inf, cost)
            cost = cost * (1.0 + 2.0 * (1.0 - np.clip(cosang, -1.0, 1.0)))
        j = int(np.argmin(cost))
        if not np.isfinite(cost[j]) or dist[j] > max_gap_m:
            break
        visited[j] = True
        step = points[j] - cur
        direction = step / max(float(np.linalg.norm(step)), 1e-9)
        order.append(j)
    return order


def _loop_centreline(left: FloatArray, right: FloatArray) -> FloatArray:
    """A closed centreline from two ordered closed boundaries (same direction)."""
    ls = resample(left, 0.25, True)
    rs = resample(right, 0.25, True)
    s_l = arc_lengths(np.vstack([left, left[:1]]), False)
    s_r = arc_lengths(np.vstack([right, right[:1]]), False)
    # left samples -> nearest on right
    _, seg_r, t_r, proj_r = nearest_on_polyline(ls, right, True)
    seg_len_r = np.diff(s_r)
    param_l1 = arc_lengths(np.vstack([ls, ls[:1]]), False)[:-1] * (s_l[-1] / max(
        polyline_length(ls, True), 1e-9))
    param_r1 = s_r[seg_r] + t_r * seg_len_r[seg_r]
    # right samples -> nearest on left
    _, seg_l, t_l, proj_l = nearest_on_polyline(rs, left, True)
    seg_len_l = np.diff(s_l)
    param_l2 = s_l[seg_l] + t_l * seg_len_l[seg_l]
    param_r2 = arc_lengths(np.vstack([rs, rs[:1]]), False)[:-1] * (s_r[-1] / max(
        polyline_length(rs, True), 1e-9))
    mid = np.vstack([(ls + proj_r) / 2.0, (rs + proj_l) / 2.0])
    p_l = np.concatenate([param_l1, param_l2])
    p_r = np.concatenate([param_r1, param_r2])
    order = np.lexsort((p_r, p_l))
    mid = mid[order]
    mid = smooth_closed(mid, 9)
    mid = resample(mid, CENTRELINE_STEP_M, True)
    return smooth_closed(mid, 5)


def _side_of(points: FloatArray, centre: FloatArray, closed: bool) -> tuple[FloatArray, FloatArray]:
    """Signed lateral offset (positive left) and progress of points against a centreline."""
    a, ab = _segments(centre, closed)
    d, seg, t, proj = nearest_on_polyline(points, centre, closed)
    seg_len = np.hypot(ab[:, 0], ab[:, 1])
    s = np.concatenate([[0.0], np.cumsum(seg_len)])[seg] + t * seg_len[seg]
    rel = points - a[seg]
    cross = ab[seg, 0] * rel[:, 1] - ab[seg, 1] * rel[:, 0]
    return np.where(cross >= 0.0, d, -d), s


def _line_from_cluster(
    cluster: FloatArray, heading_rad: float
) -> FloatArray:
    """A start/finish line (2,2) across the track through a cluster of gate cones."""
    mid = cluster.mean(axis=0)
    nx, ny = -math.sin(heading_rad), math.cos(heading_rad)
    lat = (cluster - mid) @ np.array([nx, ny])
    half = max(float(np.abs(lat).max()), 1.0)
    return np.array([[mid[0] - half * nx, mid[1] - half * ny],
                     [mid[0] + half * nx, mid[1] + half * ny]])


def _clusters(points: FloatArray, radius_m: float) -> list[FloatArray]:
    """Simple single-link clusters of points within ``radius_m`` of each other."""
    n = len(points)
    label = -np.ones(n, int)
    k = 0
    for i in range(n):
        if label[i] >= 0:
            continue
        stack = [i]
        label[i] = k
        while stack:
            j = stack.pop()
            near = np.nonzero((np.hypot(*(points - points[j]).T) <= radius_m) & (label < 0))[0]
            label[near] = k
            stack.extend(near.tolist())
        k += 1
    return [points[label == c] for c in range(k)]


def _classify(raw: _RawLayout) -> str:
    lname = raw.name.lower()
    if "skidpad" in lname or "skid_pad" in lname:
        return "skidpad"
    if "accel" in lname:
        return "acceleration"
    xy = raw.xy - raw.xy.mean(axis=0)
    if len(xy) >= 4:
        sv = np.linalg.svd(xy, compute_uv=False) / math.sqrt(len(xy))
        if sv[1] < 3.0 and sv[0] > 15.0:
            return "acceleration"
    return "trackdrive"


def build_track(raw: _RawLayout) -> Track:
    """Turn cones in a file frame into a world-frame :class:`Track` (kind auto-detected)."""
    if len(raw.xy) < 4:
        raise TrackError(f"{raw.source}: only {len(raw.xy)} cones, a track needs at least 4")
    kind = _classify(raw)
    if kind == "acceleration":
        return _build_acceleration(raw)
    if kind == "skidpad":
        return _build_skidpad(raw)
    return _build_trackdrive(raw)


def _finish(raw: _RawLayout, kind: str, pose: tuple[float, float, float], centre: FloatArray,
            left: FloatArray, right: FloatArray, is_loop: bool,
            start_line: FloatArray, finish_line: FloatArray) -> Track:
    """Move everything into the frame of ``pose`` and make the Track."""
    def tf(a: FloatArray) -> FloatArray:
        return _transform(a, pose) if len(a) else np.zeros((0, 2))

    centre_w = tf(centre)
    if is_loop:
        # start the centreline at the sample nearest the car, oriented with the car
        k = int(np.argmin(np.hypot(*centre_w.T)))
        centre_w = np.roll(centre_w, -k, axis=0)
    track = Track(
        name=raw.name,
        cones_xy_m=tf(raw.xy),
        colours=raw.colours,
        sizes=raw.sizes,
        centreline_xy_m=centre_w,
        left_xy_m=tf(left),
        right_xy_m=tf(right),
        width_m=0.0,
        is_loop=is_loop,
        lap_length_m=polyline_length(centre_w, is_loop),
        kind=kind,
        start_line_xy_m=tf(start_line) if np.all(np.isfinite(start_line)) else start_line,
        finish_line_xy_m=tf(finish_line) if np.all(np.isfinite(finish_line)) else finish_line,
        source=raw.source,
    )
    track.width_m = float(np.median(track.widths_m)) if kind != "skidpad" else 3.0
    return track


def _build_trackdrive(raw: _RawLayout) -> Track:
    xy, col = raw.xy, raw.colours
    left_mask = col == ConeColour.BLUE
    right_mask = col == ConeColour.YELLOW
    if raw.side_hint is not None:
        left_mask = left_mask | (raw.side_hint > 0)
        right_mask = right_mask | (raw.side_hint < 0)
    if left_mask.sum() < 3 or right_mask.sum() < 3:
        raise TrackError(
            f"{raw.source}: a trackdrive needs at least 3 blue (left) and 3 yellow (right) cones,"
            f" got {int(left_mask.sum())} and {int(right_mask.sum())}")
    big = xy[col == ConeColour.BIG_ORANGE]
    if raw.start_pose is not None:
        start_xy = np.array(raw.start_pose[:2])
        start_dir: FloatArray | None = np.array([math.cos(raw.start_pose[2]),
                                                 math.sin(raw.start_pose[2])])
    elif len(big):
        start_xy = big.mean(axis=0)
        start_dir = None
    else:
        start_xy = xy[left_mask][0]
        start_dir = None
    lpts, rpts = xy[left_mask], xy[right_mask]
    lorder = _order_chain(lpts, start_xy, start_dir)
    ldir = lpts[lorder[1]] - lpts[lorder[0]] if len(lorder) > 1 else start_dir
    rorder = _order_chain(rpts, lpts[lorder[0]], ldir)
    for side, order, pts in (("left", lorder, lpts), ("right", rorder, rpts)):
        if len(order) < 0.8 * len(pts) or len(order) < 3:
            raise TrackError(
                f"{raw.source}: cannot order the {side} cones into one boundary"
                f" ({len(order)} of {len(pts)} chained; gaps over 12 m?)")
        if len(order) < len(pts):
            log.warning("%s: %d %s cones left out of the boundary chain", raw.source,
                        len(pts) - len(order), side)
    left, right = lpts[lorder], rpts[rorder]
    centre = _loop_centreline(left, right)
    # orient: blue on the left
    lat_l, _ = _side_of(lpts, centre, True)
    if np.median(lat_l) < 0.0:
        centre = centre[::-1].copy()
    # side of every cone, and boundaries ordered along the centreline
    lat, s = _side_of(xy, centre, True)
    cone_side = np.where(left_mask, 1, np.where(right_mask, -1, np.sign(lat))).astype(int)
    lsel = np.nonzero(cone_side > 0)[0]
    rsel = np.nonzero(cone_side < 0)[0]
    left = xy[lsel[np.argsort(s[lsel], kind="stable")]]
    right = xy[rsel[np.argsort(s[rsel], kind="stable")]]
    centre_heading = _headings(centre, True)
    # start line from the big orange cones (the cluster nearest the start)
    start_line = np.full((2, 2), np.nan)
    if len(big) >= 2:
        clusters = _clusters(big, 7.0)
        ref = start_xy
        gate = min(clusters, key=lambda c: float(np.hypot(*(c.mean(axis=0) - ref))))
        if len(gate) >= 2:
            _, gs = _side_of(gate.mean(axis=0)[None], centre, True)
            k = int(np.argmin(np.hypot(*(centre - gate.mean(axis=0)).T)))
            start_line = _line_from_cluster(gate, float(centre_heading[k]))
    pose = raw.start_pose
    if pose is None:
        pose = _inferred_pose(raw, centre, centre_heading, start_line)
    else:
        k = int(np.argmin(np.hypot(*(centre - np.array(pose[:2])).T)))
        if abs(wrap_angle(float(centre_heading[k]) - pose[2])) > math.pi / 2:
            log.warning("%s: the start pose faces against the blue-left direction", raw.source)
    return _finish(raw, "trackdrive", pose, centre, left, right, True, start_line, start_line)


def _headings(poly: FloatArray, closed: bool) -> FloatArray:
    if closed:
        nxt = np.roll(poly, -1, axis=0)
    else:
        nxt = np.vstack([poly[1:], 2 * poly[-1:] - poly[-2:-1]])
    d = nxt - poly
    return np.arctan2(d[:, 1], d[:, 0])


def _inferred_pose(raw: _RawLayout, centre: FloatArray, heading: FloatArray,
                   start_line: FloatArray) -> tuple[float, float, float]:
    if np.all(np.isfinite(start_line)):
        k = int(np.argmin(np.hypot(*(centre - start_line.mean(axis=0)).T)))
    else:
        k = 0
    back = int(round(START_BEHIND_LINE_M / CENTRELINE_STEP_M))
    j = (k - back) % len(centre)
    log.info("%s: no start pose in the file; starting %.1f m before the start line",
             raw.source, START_BEHIND_LINE_M)
    return float(centre[j, 0]), float(centre[j, 1]), float(heading[j])


def _build_acceleration(raw: _RawLayout) -> Track:
    xy = raw.xy
    mean = xy.mean(axis=0)
    _, _, vt = np.linalg.svd(xy - mean)
    axis = vt[0]
    if raw.start_pose is not None:
        sx, sy, syaw = raw.start_pose
        if axis @ np.array([math.cos(syaw), math.sin(syaw)]) < 0:
            axis = -axis
    else:
        big = xy[raw.colours == ConeColour.BIG_ORANGE]
        along_all = (xy - mean) @ axis
        ref = big if len(big) else xy
        # start at the end where the big orange cones are (or the first cones)
        if ((ref - mean) @ axis).min() > along_all.min() + 0.5 * np.ptp(along_all):
            axis = -axis
    normal = np.array([-axis[1], axis[0]])
    along = (xy - mean) @ axis
    lat = (xy - mean) @ normal
    if raw.start_pose is None:
        big = raw.colours == ConeColour.BIG_ORANGE
        first = float(along[big].min()) if big.any() else float(along.min())
        s0 = first - START_BEHIND_LINE_M
        p = mean + s0 * axis
        pose = (float(p[0]), float(p[1]), math.atan2(axis[1], axis[0]))
        log.info("%s: no start pose in the file; starting %.1f m before the first gate",
                 raw.source, START_BEHIND_LINE_M)
    else:
        pose = raw.start_pose
    s_start = float((np.array(pose[:2]) - mean) @ axis)
    s_end = float(along.max())
    n = max(int(round((s_end - s_start) / CENTRELINE_STEP_M)), 2)
    q = np.linspace(s_start, s_end, n + 1)
    centre = mean + q[:, None] * axis[None, :]
    left_sel = np.nonzero(lat > 0)[0]
    right_sel = np.nonzero(lat <= 0)[0]
    left = xy[left_sel[np.argsort(along[left_sel])]]
    right = xy[right_sel[np.argsort(along[right_sel])]]
    heading = math.atan2(axis[1], axis[0])
    start_line = np.full((2, 2), np.nan)
    finish_line = np.full((2, 2), np.nan)
    big_pts = xy[raw.colours == ConeColour.BIG_ORANGE]
    if len(big_pts) >= 2:
        gates = sorted(_clusters(big_pts, 7.0), key=lambda c: float((c.mean(axis=0) - mean)
                                                                     @ axis))
        start_line = _line_from_cluster(gates[0], heading)
        finish_line = _line_from_cluster(gates[-1], heading) if len(gates) > 1 else start_line
    return _finish(raw, "acceleration", pose, centre, left, right, False, start_line,
                   finish_line)


def _fit_circle(pts: FloatArray) -> tuple[FloatArray, float]:
    """Algebraic (Kasa) circle fit: centre (2,), radius."""
    a = np.column_stack([2 * pts[:, 0], 2 * pts[:, 1], np.ones(len(pts))])
    b = (pts ** 2).sum(axis=1)
    sol, *_ = np.linalg.lstsq(a, b, rcond=None)
    c = sol[:2]
    return c, float(math.sqrt(max(sol[2] + c @ c, 0.0)))


def _build_skidpad(raw: _RawLayout) -> Track:
    xy, col = raw.xy, raw.colours
    big = xy[col == ConeColour.BIG_ORANGE]
    if raw.start_pose is not None:
        pose0 = raw.start_pose
    elif len(big):
        # unknown heading: assume the car drives towards the gate from the far side
        g = big.mean(axis=0)
        pose0 = (float(g[0]), float(g[1]), 0.0)
    else:
        raise TrackError(f"{raw.source}: skidpad without start pose or big orange gate")
    w = _transform(xy, pose0)
    centres: list[FloatArray] = []
    radii: list[float] = []
    for sign in (-1.0, 1.0):  # right circle (y < 0) first, then left
        side = (w[:, 1] * sign > 1.0)
        best: tuple[FloatArray, float] | None = None
        for colour in (ConeColour.BLUE, ConeColour.YELLOW):
            pts = w[side & (col == colour)]
            if len(pts) >= 5:
                c, r = _fit_circle(pts)
                if best is None or r < best[1]:
                    best = (c, r)
        if best is None:
            raise TrackError(f"{raw.source}: skidpad circles not found (too few blue/yellow"
                             f" cones on one side)")
        inner_c, inner_r = best
        ring = w[side & ((col == ConeColour.BLUE) | (col == ConeColour.YELLOW))]
        d = np.hypot(*(ring - inner_c).T)
        outer = d[d > inner_r + 1.0]
        outer_r = float(np.median(outer)) if len(outer) else inner_r + 3.0
        centres.append(inner_c)
        radii.append(0.5 * (inner_r + outer_r))
    cr, cl = centres
    r = 0.5 * (radii[0] + radii[1])
    x_cross = 0.5 * (cr[0] + cl[0])
    y_cross = 0.5 * (cr[1] + cl[1])
    parts: list[FloatArray] = []
    # entry straight
    n_in = max(int(x_cross / CENTRELINE_STEP_M), 2)
    parts.append(np.column_stack([np.linspace(0.0, x_cross, n_in, endpoint=False),
                                np.linspace(0.0, y_cross, n_in, endpoint=False)]))
    n_c = max(int(2 * math.pi * r / CENTRELINE_STEP_M), 8)
    ang = np.linspace(0.0, 4 * math.pi, 2 * n_c, endpoint=False)
    # right circle, clockwise, starting at the top of it (the crossing point)
    a0 = math.atan2(y_cross - cr[1], x_cross - cr[0])
    parts.append(np.column_stack([cr[0] + r * np.cos(a0 - ang), cr[1] + r * np.sin(a0 - ang)]))
    a1 = math.atan2(y_cross - cl[1], x_cross - cl[0])
    parts.append(np.column_stack([cl[0] + r * np.cos(a1 + ang), cl[1] + r * np.sin(a1 + ang)]))
    far = float(w[:, 0].max()) - 3.0  # end of the exit lane, short of the last cones
    n_out = max(int((far - x_cross) / CENTRELINE_STEP_M), 2)
    parts.append(np.column_stack([np.linspace(x_cross, far, n_out),
                                np.full(n_out, y_cross)]))
    centre_w = np.vstack(parts)
    # back to the file frame so _finish can transform uniformly
    c0, s0 = math.cos(pose0[2]), math.sin(pose0[2])
    centre = np.column_stack([pose0[0] + centre_w[:, 0] * c0 - centre_w[:, 1] * s0,
                              pose0[1] + centre_w[:, 0] * s0 + centre_w[:, 1] * c0])
    left = xy[col == ConeColour.BLUE]
    right = xy[col == ConeColour.YELLOW]
    start_line = np.full((2, 2), np.nan)
    if len(big) >= 2:
        start_line = _line_from_cluster(big, pose0[2])
    return _finish(raw, "skidpad", pose0, centre, left, right, False, start_line, start_line)


# ---------------------------------------------------------------------------------------------
# File formats
# ---------------------------------------------------------------------------------------------


def parse_eufs_csv(path: Path) -> _RawLayout:
    """Read an EUFS CSV track file (repeated headers and blank lines are skipped)."""
    try:
        text = path.read_text(encoding="utf-8", errors="replace")
    except OSError as exc:
        raise TrackError(f"{path}: cannot read ({exc.strerror})") from None
    xy: list[tuple[float, float]] = []
    colours: list[int] = []
    sizes: list[int] = []
    start: tuple[float, float, float] | None = None
    for lineno, line in enumerate(text.splitlines(), 1):
        fields = [f.strip() for f in line.split(",")]
        if not line.strip() or line.lstrip().startswith("#"):
            continue
        tag = fields[0].lower()
        if tag == "tag":
            continue
        if len(fields) < 3:
            raise TrackError(f"{path}:{lineno}: expected 'tag,x,y,...', got {line.strip()!r}")
        try:
            x, y = float(fields[1]), float(fields[2])
            direction = float(fields[3]) if len(fields) > 3 and fields[3] else 0.0
        except ValueError:
            raise TrackError(f"{path}:{lineno}: x/y/direction not numbers in"
                             f" {line.strip()!r}") from None
        if not (math.isfinite(x) and math.isfinite(y)):
            raise TrackError(f"{path}:{lineno}: non-finite cone position")
        if tag == "car_start":
            if start is not None:
                log.warning("%s:%d: second car_start row ignored", path, lineno)
            else:
                start = (x, y, direction)
            continue
        if tag in _EUFS_NON_CONE_TAGS:
            continue
        if tag not in _EUFS_TAGS:
            raise TrackError(f"{path}:{lineno}: unknown tag {fields[0]!r} (expected one of"
                             f" {', '.join(sorted(_EUFS_TAGS))}, car_start, midpoint)")
        c, s = _EUFS_TAGS[tag]
        xy.append((x, y))
        colours.append(int(c))
        sizes.append(int(s))
    if not xy:
        raise TrackError(f"{path}: no cones found (is it an EUFS track CSV?)")
    return _RawLayout(path.stem, str(path), np.array(xy, np.float64),
                      np.array(colours, np.int64), np.array(sizes, np.int64), start)


def parse_fssim_yaml(path: Path, car_front_to_origin_m: float = FRONT_WING_TO_ORIGIN_M
                     ) -> _RawLayout:
    """Read an AMZ FSSIM track YAML; ``starting_pose_front_wing`` (x, y, yaw of the front wing)
    becomes the vehicle-origin start pose ``car_front_to_origin_m`` behind it."""
    try:
        with path.open(encoding="utf-8") as fh:
            data = yaml.safe_load(fh)
    except OSError as exc:
        raise TrackError(f"{path}: cannot read ({exc.strerror})") from None
    except yaml.YAMLError as exc:
        raise TrackError(f"{path}: not valid YAML ({exc})") from None
    if not isinstance(data, dict):
        raise TrackError(f"{path}: expected a YAML mapping with cones_left/cones_right")
    keys = (("cones_left", ConeColour.BLUE, ConeSize.SMALL, 1),
            ("cones_right", ConeColour.YELLOW, ConeSize.SMALL, -1),
            ("cones_orange", ConeColour.ORANGE, ConeSize.SMALL, 0),
            ("cones_orange_big", ConeColour.BIG_ORANGE, ConeSize.LARGE, 0))
    if not any(k in data for k, *_ in keys):
        raise TrackError(f"{path}: none of {', '.join(k for k, *_ in keys)} found")
    xy: list[FloatArray] = []
    colours: list[int] = []
    sizes: list[int] = []
    sides: list[int] = []
    for key, colour, size, side in keys:
        items = data.get(key) or []
        try:
            arr = np.asarray(items, np.float64).reshape(-1, 2) if len(items) else np.zeros((0, 2))
        except (ValueError, TypeError):
            raise TrackError(f"{path}: '{key}' must be a list of [x, y] pairs") from None
        if not np.all(np.isfinite(arr)):
            raise TrackError(f"{path}: '{key}' has non-finite coordinates")
        xy.append(arr)
        colours += [int(colour)] * len(arr)
        sizes += [int(size)] * len(arr)
        sides += [side] * len(arr)
    start: tuple[float, float, float] | None = None
    pose = data.get("starting_pose_front_wing")
    if pose is not None:
        try:
            px, py, pyaw = (float(v) for v in list(pose)[:3])
        except (ValueError, TypeError):
            raise TrackError(f"{path}: 'starting_pose_front_wing' must be [x, y, yaw]") from None
        start = (px - car_front_to_origin_m * math.cos(pyaw),
                 py - car_front_to_origin_m * math.sin(pyaw), pyaw)
    return _RawLayout(path.stem, str(path), np.vstack(xy), np.array(colours, np.int64),
                      np.array(sizes, np.int64), start, np.array(sides, np.int64))


def load_track(name_or_path: str) -> Track:
    """A track by name: ``"default"``, ``"gen:SEED"`` (a generated trackdrive), ``"hard:NAME"``
    (:mod:`simulator.hard_tracks`), or a path to an
    EUFS ``.csv`` or AMZ FSSIM ``.yaml`` file. Raises :class:`TrackError` with a clear message."""
    if name_or_path == "default":
        from simulator.track_generator import default_track

        return default_track()
    if name_or_path.startswith("gen:"):
        from simulator.track_generator import generate_track

        try:
            seed = int(name_or_path[4:])
        except ValueError:
            raise TrackError(f"track {name_or_path!r}: expected gen:SEED with an integer seed"
                             ) from None
        if seed < 0:
            raise TrackError(f"track {name_or_path!r}: the seed of gen:SEED must be >= 0")
        return generate_track(seed)
    if name_or_path.startswith("hard:"):
        from simulator.hard_tracks import hard_track

        return hard_track(name_or_path[5:])
    path = Path(name_or_path)
    if not path.exists():
        raise TrackError(f"track {name_or_path!r}: no such file (use 'default', 'gen:SEED',"
                         f" or a .csv / .yaml track file)")
    suffix = path.suffix.lower()
    if suffix == ".csv":
        raw = parse_eufs_csv(path)
    elif suffix in (".yaml", ".yml"):
        raw = parse_fssim_yaml(path)
    else:
        raise TrackError(f"{path}: unknown track format {suffix!r} (expected .csv or .yaml)")
    return build_track(raw)
