"""Waypoints: the book recorded on the exploration drive, and waypoints from the cone map.

Seed 002, 3.2.1: waypoints are recorded during the manual drive; a waypoint is dropped once the
car comes within 2.5 m of it and the next ones are served. When there was no exploration drive,
:func:`waypoints_from_cones` makes them from the cone map: midpoints of the blue-yellow edges of a
Delaunay triangulation, ordered into a path from the car forward.
"""

from __future__ import annotations

import logging
import math

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial import Delaunay, QhullError, cKDTree

from common.messages import ConeColour

logger = logging.getLogger(__name__)

FloatArray = NDArray[np.float64]


class WaypointBook:
    """Waypoints recorded from the estimated pose, served in order of travel.

    ``spacing_m``: distance between recorded waypoints; ``reach_m``: a served waypoint is dropped
    when the car is within it; ``served``: how many upcoming waypoints :meth:`next_waypoints`
    gives. A closed book (a lap) wraps around.
    """

    def __init__(self, spacing_m: float = 1.5, reach_m: float = 2.5, served: int = 3) -> None:
        self.spacing_m = spacing_m
        self.reach_m = reach_m
        self.served = served
        self._points: list[tuple[float, float]] = []
        self._xy = np.zeros((0, 2))
        self.closed = False
        self.cursor = 0
        self.rejected = 0

    def __len__(self) -> int:
        return len(self._points) if not len(self._xy) else len(self._xy)

    @property
    def points_xy_m(self) -> FloatArray:
        """All waypoints (N, 2) (m)."""
        if len(self._xy):
            return self._xy
        return np.asarray(self._points, np.float64).reshape(-1, 2)

    def record(self, x_m: float, y_m: float) -> bool:
        """Record the car's position if it moved ``spacing_m`` from the last waypoint."""
        if not (math.isfinite(x_m) and math.isfinite(y_m)):
            self.rejected += 1
            logger.warning("waypoint rejected: non-finite position (%s, %s)", x_m, y_m)
            return False
        if self._points:
            lx, ly = self._points[-1]
            if math.hypot(x_m - lx, y_m - ly) < self.spacing_m:
                return False
        self._points.append((float(x_m), float(y_m)))
        return True

    def set_points(self, points_xy_m: ArrayLike, closed: bool) -> None:
        """Replace the book (e.g. waypoints from the cone map, or one closed lap of the drive)."""
        self._xy = np.asarray(points_xy_m, np.float64).reshape(-1, 2).copy()
        self._points = [(float(p[0]), float(p[1])) for p in self._xy]
        self.closed = closed
        self.cursor = 0

    def close_loop(self, close_distance_m: float = 4.0, min_length_m: float = 30.0,
                   bridge_max_m: float = 0.0) -> bool:
        """Cut the recorded drive to one lap if it came back to its start; True if it did.

        The lap ends at the waypoint nearest the first one after at least ``min_length_m`` of
        driving (and past half the drive), if that is within ``close_distance_m``. A drive
        that stopped short of its start (the map's loop closed before the car got there) is a
        lap too when its end is within ``bridge_max_m`` of the start and heads for it: the
        periodic baseframe bridges the gap.
        """
        if self.closed:  # already one lap (set_points(..., closed=True))
            return True
        pts = self.points_xy_m
        if len(pts) < 8:
            return False
        travelled = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(pts, axis=0), axis=1))])
        dist0 = np.linalg.norm(pts - pts[0], axis=1)
        candidates = np.nonzero((travelled >= min_length_m) & (dist0 <= close_distance_m))[0]
        if len(candidates) == 0:
            if travelled[-1] >= min_length_m and self._heads_for_start(pts, bridge_max_m):
                self.set_points(pts, closed=True)
                return True
            self.set_points(pts, closed=False)
            return False
        # first return to the start: the first run of candidates, its closest point
        first = candidates[0]
        run = [first]
        for c in candidates[1:]:
            if c != run[-1] + 1:
                break
            run.append(int(c))
        end = int(run[int(np.argmin(dist0[run]))])
        lap = pts[:end]  # the point at `end` is (about) the first one again
        self.set_points(lap, closed=True)
        return True

    @staticmethod
    def _heads_for_start(pts: FloatArray, bridge_max_m: float, max_turn_rad: float = 0.6
                         ) -> bool:
        """The drive ends within ``bridge_max_m`` of its start, heading for it, and the gap
        joins the start in the start's direction."""
        gap = pts[0] - pts[-1]
        length = float(np.hypot(gap[0], gap[1]))
        if length > bridge_max_m or length < 1e-6:
            return False
        end_dir = pts[-1] - pts[-2]
        start_dir = pts[1] - pts[0]
        gap_yaw = math.atan2(gap[1], gap[0])
        turns = (math.remainder(gap_yaw - math.atan2(end_dir[1], end_dir[0]), 2.0 * math.pi),
                 math.remainder(gap_yaw - math.atan2(start_dir[1], start_dir[0]), 2.0 * math.pi))
        return all(abs(t) <= max_turn_rad for t in turns)

    def next_waypoints(self, x_m: float, y_m: float) -> FloatArray:
        """Drop the waypoints the car has reached (or passed: the next one is nearer) and serve
        the next ones (served, 2) (m)."""
        pts = self.points_xy_m
        n = len(pts)
        if n == 0:
            return np.zeros((0, 2))
        if math.isfinite(x_m) and math.isfinite(y_m):
            for _ in range(n):
                if self.cursor >= n:
                    if not self.closed:
                        break
                    self.cursor = 0
                wx, wy = pts[self.cursor]
                dist = math.hypot(wx - x_m, wy - y_m)
                if dist > self.reach_m:
                    # passed by without reaching it: drop it when the next one is nearer
                    nxt = self.cursor + 1
                    if nxt >= n:
                        if not self.closed:
                            break
                        nxt = 0
                    if math.hypot(pts[nxt][0] - x_m, pts[nxt][1] - y_m) >= dist:
                        break
                self.cursor += 1
            if self.closed:
                self.cursor %= n
        if self.closed:
            idx = (self.cursor + np.arange(min(self.served, n))) % n
        else:
            idx = np.arange(self.cursor, min(self.cursor + self.served, n))
        return pts[idx]


def cone_midpoints(
    cones_xy_m: ArrayLike,
    colours: ArrayLike,
    min_pair_m: float = 2.0,
    max_pair_m: float = 7.0,
) -> FloatArray:
    """Midpoints (K, 2) of Delaunay edges that join a blue and a yellow cone (track crossings)."""
    xy = np.asarray(cones_xy_m, np.float64).reshape(-1, 2)
    col = np.asarray(colours, np.int64).reshape(-1)
    keep = (col == int(ConeColour.BLUE)) | (col == int(ConeColour.YELLOW))
    keep &= np.all(np.isfinite(xy), axis=1)
    xy, col = xy[keep], col[keep]
    if len(xy) < 3 or len(np.unique(col)) < 2:
        return np.zeros((0, 2))
    try:
        tri = Delaunay(xy)
    except (QhullError, ValueError) as exc:
        logger.warning("Delaunay triangulation of %d cones failed: %s", len(xy), exc)
        return np.zeros((0, 2))
    s = tri.simplices
    edges = np.vstack([s[:, [0, 1]], s[:, [1, 2]], s[:, [2, 0]]])
    edges = np.unique(np.sort(edges, axis=1), axis=0)
    a, b = edges[:, 0], edges[:, 1]
    length = np.linalg.norm(xy[a] - xy[b], axis=1)
    cross = (col[a] != col[b]) & (length >= min_pair_m) & (length <= max_pair_m)
    return np.asarray(0.5 * (xy[a[cross]] + xy[b[cross]]), np.float64)


def order_path(
    points_xy_m: ArrayLike,
    start_xy_m: tuple[float, float],
    start_yaw_rad: float,
    max_step_m: float = 8.0,
    max_turn_rad: float = 1.2,
    dedupe_m: float = 1.0,
) -> FloatArray:
    """Order scattered path points into a path from the car forward.

    Greedy: from the car, repeatedly take the nearest unused point within ``max_step_m`` whose
    direction differs from the current heading by less than ``max_turn_rad``. Points within
    ``dedupe_m`` of each other are merged first.
    """
    pts = np.asarray(points_xy_m, np.float64).reshape(-1, 2)
    if len(pts) == 0:
        return pts
    # merge near-duplicates
    tree = cKDTree(pts)
    groups = tree.query_ball_point(pts, dedupe_m)
    used = np.zeros(len(pts), bool)
    merged = []
    for i, g in enumerate(groups):
        if used[i]:
            continue
        g = [j for j in g if not used[j]]
        used[g] = True
        merged.append(pts[g].mean(axis=0))
    pts = np.asarray(merged)
    tree = cKDTree(pts)
    free = np.ones(len(pts), bool)
    pos = np.asarray(start_xy_m, np.float64)
    yaw = start_yaw_rad
    path = []
    start = pos.copy()
    for _ in range(len(pts)):
        best = -1
        # a gap (e.g. the start line, marked by orange cones only): look further, straighter
        for reach, turn_max in ((max_step_m, max_turn_rad), (2.0 * max_step_m, 0.4)):
            best, best_cost = -1, math.inf
            for j in tree.query_ball_point(pos, reach):
                if not free[j]:
                    continue
                d = pts[j] - pos
                dist = float(np.hypot(d[0], d[1]))
                if dist < 1e-6:
                    free[j] = False
                    continue
                turn = abs(math.remainder(math.atan2(d[1], d[0]) - yaw, 2.0 * math.pi))
                if turn > turn_max:
                    continue
                cost = dist * (1.0 + 2.0 * turn)
                if cost < best_cost:
                    best, best_cost = j, cost
            if best >= 0:
                break
        if best < 0:
            break
        d = pts[best] - pos
        yaw = math.atan2(d[1], d[0])
        pos = pts[best]
        free[best] = False
        path.append(pos)
        # do not sweep up points left behind beside the path
        for j in tree.query_ball_point(pos, 1.5):
            free[j] = False
        if len(path) > 10 and np.hypot(*(pos - start)) < max_step_m * 0.6:
            break
    return np.asarray(path, np.float64).reshape(-1, 2)


def waypoints_from_cones(
    cones_xy_m: ArrayLike,
    colours: ArrayLike,
    start_xy_m: tuple[float, float],
    start_yaw_rad: float,
    *,
    min_pair_m: float = 2.0,
    max_pair_m: float = 7.0,
    track_width_m: float = 3.5,
    max_step_m: float = 8.0,
    max_turn_rad: float = 1.2,
    close_distance_m: float = 6.0,
    min_loop_length_m: float = 30.0,
) -> tuple[FloatArray, bool]:
    """Waypoints (K, 2) through the middle of the track from the cone map, and whether they close
    a lap. Blue cones are on the left, yellow on the right. With only one side coloured the path
    runs half a track width inside that side.
    """
    xy = np.asarray(cones_xy_m, np.float64).reshape(-1, 2)
    col = np.asarray(colours, np.int64).reshape(-1)
    mids = cone_midpoints(xy, col, min_pair_m, max_pair_m)
    if len(mids) >= 3:
        path = order_path(mids, start_xy_m, start_yaw_rad, max_step_m, max_turn_rad)
    else:
        path = np.zeros((0, 2))
    if len(path) < 3:
        # one side only: follow that side's cones and offset them into the track
        for colour, side in ((ConeColour.BLUE, -1.0), (ConeColour.YELLOW, 1.0)):
            pts = xy[col == int(colour)]
            if len(pts) < 3:
                continue
            # start beside the car: order from a point half a width toward that side
            c, s = math.cos(start_yaw_rad), math.sin(start_yaw_rad)
            shift = -side * track_width_m / 2.0
            origin = (start_xy_m[0] - s * shift, start_xy_m[1] + c * shift)
            line = order_path(pts, origin, start_yaw_rad, max_step_m, max_turn_rad, dedupe_m=0.5)
            if len(line) < 3:
                continue
            line = np.vstack([np.asarray(origin)[None, :], line])
            tangent = np.gradient(line, axis=0)
            tangent /= np.maximum(np.linalg.norm(tangent, axis=1, keepdims=True), 1e-9)
            normal_left = np.stack([-tangent[:, 1], tangent[:, 0]], axis=1)
            path = (line + normal_left * side * track_width_m / 2.0)[1:]
            break
    if len(path) < 3:
        return np.zeros((0, 2)), False
    travelled = float(np.sum(np.linalg.norm(np.diff(path, axis=0), axis=1)))
    gap = float(np.linalg.norm(path[-1] - path[0]))
    closed = travelled >= min_loop_length_m and gap <= close_distance_m
    start = np.asarray(start_xy_m, np.float64)
    if not closed:
        # begin at the car so the frame covers where it is
        path = np.vstack([start[None, :], path])
    return path, closed
