"""The simulator's track: a cone layout with the queries the simulated world asks of it.

Where a point is along the centreline and how far to the side (:meth:`Track.locate`, a walk
from the previous segment for the car's every step), the centreline point at a progress, the
cones a car footprint touches and whether it is off the track. Tracks are built by
:mod:`simulator.track_layouts` (from cones), :mod:`simulator.track_generator` (generated and
default layouts) and loaded by name or file with :func:`simulator.tracks.load_track`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from common.errors import TrackError
from common.messages import ConeSize
from common.polyline import FloatArray, nearest_on_polyline, segments
from common.track import TrackLayout

SMALL_CONE_RADIUS_M = 0.228 / 2.0
"""Base radius of a small cone (228 mm base)."""
LARGE_CONE_RADIUS_M = 0.285 / 2.0
"""Base radius of a large cone (285 mm base)."""


@dataclass(frozen=True, eq=False)
class Track(TrackLayout):
    """A :class:`~common.track.TrackLayout` with what the simulated world asks of it: where a
    point is along the centreline (:meth:`locate`), the cones a footprint touches, whether it is
    off the track.

    ``kind`` is ``trackdrive``, ``acceleration`` or ``skidpad``; ``start_line_xy_m`` (2, 2) the
    ends of the start/finish line (NaN when unknown); ``finish_line_xy_m`` differs from it only
    for acceleration; ``source`` the file it came from. Derived on construction: the
    centreline's arc length at each sample ``centreline_s_m`` (M,), the half widths left and
    right of it (M,) and each cone's base radius (N,) (m).
    """

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
        TrackLayout.__post_init__(self)
        n = len(self.cones_xy_m)
        if self.colours.shape != (n,) or self.sizes.shape != (n,):
            raise TrackError(f"track {self.name!r}: colours/sizes do not match {n} cones")
        if len(self.centreline_xy_m) < 2:
            raise TrackError(f"track {self.name!r}: centreline has fewer than 2 points")
        c = self.centreline_xy_m
        seg_a, seg_ab = segments(c, self.is_loop)
        self._set(_seg_a=seg_a, _seg_ab=seg_ab)
        self._set(_seg_len=np.hypot(seg_ab[:, 0], seg_ab[:, 1]))
        self._set(centreline_s_m=np.concatenate([[0.0], np.cumsum(self._seg_len)])[: len(c)])
        self._set(_seg_list=[(float(a[0]), float(a[1]), float(b[0]), float(b[1]),
                              max(float(b[0] * b[0] + b[1] * b[1]), 1e-12))
                             for a, b in zip(seg_a, seg_ab, strict=True)],
                  _s_list=self.centreline_s_m.tolist(), _len_list=self._seg_len.tolist(),
                  cone_radius_m=np.where(self.sizes == ConeSize.LARGE, LARGE_CONE_RADIUS_M,
                                         SMALL_CONE_RADIUS_M))
        left_hw, right_hw = half_widths(c, self.left_xy_m, self.right_xy_m, self.kind,
                                        self.is_loop)
        self._set(left_half_width_m=left_hw, right_half_width_m=right_hw)
        self._build_grid()

    def _set(self, **values: object) -> None:
        """Set derived attributes of this frozen instance (in ``__post_init__`` only)."""
        for name, value in values.items():
            object.__setattr__(self, name, value)

    # -- derived data -------------------------------------------------------------------------

    def _build_grid(self) -> None:
        cell = self._grid_cell_m
        grid: dict[tuple[int, int], list[int]] = {}
        cone_list: list[tuple[float, float, float]] = []
        for i, ((x, y), r) in enumerate(zip(self.cones_xy_m.tolist(),
                                            self.cone_radius_m.tolist(), strict=True)):
            grid.setdefault((math.floor(x / cell), math.floor(y / cell)), []).append(i)
            cone_list.append((x, y, r))
        self._set(_grid=grid, _cone_list=cone_list)

    @property
    def widths_m(self) -> FloatArray:
        """Track width at each centreline sample (M,), from the boundary polylines (m)."""
        return self.left_half_width_m + self.right_half_width_m

    def check_drivable(self, car_width_m: float, cone_radius_m: float = 0.15) -> None:
        """Raise :class:`TrackError` when the track is narrower than the car between the cones
        along more than a twentieth of its length (a layout drawn at the wrong scale, or
        boundaries swapped): no driver, person or planner, can get round it."""
        widths = self.widths_m
        if len(widths) == 0:
            return
        typical_m = float(np.percentile(widths, 5.0))
        needed_m = car_width_m + 2.0 * cone_radius_m
        if typical_m < needed_m:
            raise TrackError(
                f"track {self.name!r} is {typical_m:.2f} m wide between cone centres along "
                f"5 % of its length (narrowest {float(np.min(widths)):.2f} m): the car needs "
                f"{needed_m:.2f} m ({car_width_m:.2f} m wide, cones {cone_radius_m:.2f} m in "
                f"radius). Check the layout's scale and its left/right cones.")

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

    def cones_touched(self, footprint_xy_m: FloatArray | list[tuple[float, float]]
                      ) -> list[int]:
        """Indices of the cones whose base circle overlaps the convex polygon ``footprint``
        (4,2) (corners in order, world frame)."""
        poly = _corner_list(footprint_xy_m)
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

    def is_off_track(self, footprint_xy_m: FloatArray | list[tuple[float, float]],
                     hint: int | None = None) -> bool:
        """True when every corner of the footprint (4,2) is beyond a track boundary (the
        Formula Student "off course": all four wheels out). For acceleration and skidpad the
        test uses the distance to the centreline against the local half width."""
        corners = _corner_list(footprint_xy_m)
        for x, y in corners:
            _, lateral, seg = self.locate(x, y, hint)
            half = self.left_half_width_m[seg] if lateral >= 0.0 else self.right_half_width_m[seg]
            if abs(lateral) <= half:
                return False
        return True


def _corner_list(footprint_xy_m: FloatArray | list[tuple[float, float]]
                 ) -> Sequence[Sequence[float]]:
    """A footprint's corners as a list of (x, y): the world's per-step list as it is (no numpy
    round trip), an array (4, 2) converted."""
    if isinstance(footprint_xy_m, list):
        return footprint_xy_m
    return list(np.asarray(footprint_xy_m, np.float64).reshape(-1, 2).tolist())


def _circle_touches_polygon(x: float, y: float, r: float,
                            poly: Sequence[Sequence[float]]) -> bool:
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


def half_widths(centre: FloatArray, left: FloatArray, right: FloatArray, kind: str,
                is_loop: bool) -> tuple[FloatArray, FloatArray]:
    """Distances (m) from each centreline sample (M,) to the left and the right boundary.

    A skidpad's path crosses itself: there both are the distance to the nearest boundary cone
    on either side (1.5 m without cones); a side without a boundary is 50 m away.
    """
    big = 50.0
    if kind == "skidpad":
        left_hw = np.full(len(centre), 1.5)
        right_hw = np.full(len(centre), 1.5)
        if len(left) and len(right):
            dl = np.min(np.hypot(*(centre[:, None, :] - left[None]).transpose(2, 0, 1)), axis=1)
            dr = np.min(np.hypot(*(centre[:, None, :] - right[None]).transpose(2, 0, 1)),
                        axis=1)
            both = np.minimum(dl, dr)
            left_hw = both.copy()
            right_hw = both.copy()
        return left_hw, right_hw
    if len(left) >= 2:
        left_hw = nearest_on_polyline(centre, left, is_loop)[0]
    else:
        left_hw = np.full(len(centre), big)
    if len(right) >= 2:
        right_hw = nearest_on_polyline(centre, right, is_loop)[0]
    else:
        right_hw = np.full(len(centre), big)
    return left_hw, right_hw
