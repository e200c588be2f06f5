"""The centre path through the cones ahead, searched over a Delaunay triangulation of them.

The classic Formula Student local planner (AMZ's, among others; written here from scratch): a
triangulation of the mapped cones (scipy's Delaunay) tiles the track with triangles whose edges
from one boundary to the other are the track's gates. A path through the track crosses a chain
of such edges, entering each triangle by one edge and leaving it by one of the other two, so the
candidate paths form a binary tree searched with a beam: an edge may be crossed when it is as
long as a gate can be and does not join two cones of one side (blue-blue, yellow-yellow), and
blue must then lie on its left and yellow on its right. Each path is scored by its length
against its bends, its gates' departure from the nominal width and its cones of unknown colour;
the best path's gates give its centre points (one per cone pair, see :func:`_centre_points`).

Why a search rather than a march from gate to gate: where two stretches of track run side by
side (a hairpin, a narrow infield) the nearest cone ahead may belong to the other stretch; a
path must cross a boundary edge to reach it, which the search never does.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import Delaunay, QhullError

from common.messages import ConeColour
from common.polyline import nearest_on_polyline
from planner.gate_rows import crossings, in_line, rows_driven

FloatArray = NDArray[np.float64]

BLUE, YELLOW = int(ConeColour.BLUE), int(ConeColour.YELLOW)

MIN_GATE_M = 1.9
"""Shortest edge that is a gate (m): the FSD minimum track width is 3 m between the cones'
inner sides; two cones of one side stand closer in a tight bend."""
MIN_ACROSS_M = MIN_GATE_M
"""Least track a gate leaves across the path's step through it (m): an edge crossed so
obliquely that less is left is a boundary seen at a slant (cones of one side, colour unknown)."""
ENTRY_AHEAD_M = 0.5
"""The car's entry gate (the one it came through into its triangle, or the march's first gate,
``planner.exploration_path``) may have its midpoint up to this far ahead of the car (m): a gate
at a slant beside it."""
MAX_GATE_WIDTHS = 2.7
"""Longest edge that is a gate, in nominal track widths (a bend's diagonal gates are longer)."""
BLIND_GATE_WIDTHS = 1.9
"""Widest gate, in nominal track widths, that a path crosses between two cones of unknown
colour: wider, the edge spans the infield between two stretches of track as often as a bend
(which its known cones, or a narrower diagonal beside it, lead through)."""
CONE_IN_GATE_FRACTION = 0.3
"""A cone nearer an edge than this fraction of the edge's length, abreast of its middle
``CONE_IN_GATE_SPAN`` (fraction of its length), stands in it: the edge is no gate."""
CONE_IN_GATE_SPAN = 0.6
ROW_TOLERANCE = 0.25
"""A cone that stands off a row's way on (:func:`planner.gate_rows.in_line`) by at most this
fraction of how far it stands beyond the row's last cone goes on that row (about 14 degrees):
without colours, the other side's row (:meth:`_Search._continues_the_other_row`); with
colours, the row of an uncoloured cone (:meth:`_Search._joins_one_row`)."""
OWN_ROW_TOLERANCE = 0.7
"""The same for the row a gate puts the cone on (about 35 degrees): a cone in line with the
other side's row is that row's unless its own row may as well bend to it (a row seen over two
cones only has no bend yet: the outer row of a hairpin turns 30 degrees a cone)."""
LANE_NARROWING = 0.6
"""A gate that leaves less track across the path than this fraction of the median of the
path's gates so far is an edge along one boundary, not a gate: a track keeps its width (the
rules' 3 m at least), and without colours the search's last step otherwise often runs along a
boundary (its midpoint on the boundary: nothing further on refutes it)."""
ROWS_TO_CAR_M = 5.0
"""Without colours, the rows of cones the car drove past run on from the end of the way
driven to the car itself when that end is at most this far from it (m): the way driven stops
a few metres short of the car (:data:`planner.explored_lap.DRIVEN_NEAR_M`); a way that ends
further off is no way to the car."""
MAX_TURN_RAD = 1.2
"""Largest change of heading from one midpoint to the next."""
SEARCH_RADIUS_M = 30.0
"""Cones further from the car than this are not triangulated."""
BEAM = 16
"""Partial paths kept at each depth of the search."""
MAX_DEPTH = 24
"""Most gates in one path."""
MERGE_M = 1.0
"""Centre points nearer than this (m) are one (the two cones of a square gate)."""

TURN_COST_PER_RAD2 = 4.0
WIDTH_COST = 2.0
UNKNOWN_COST = 0.25
LENGTH_REWARD_PER_M = 1.0
SKIP_COST_PER_M = 1.0
REACH_REWARD_PER_GATE = 5.0


@dataclass(frozen=True)
class _Partial:
    points: tuple[tuple[float, float], ...]
    triangle: int
    entry: tuple[int, int]
    yaw_rad: float
    cost: float
    triangles: frozenset[int]
    gates: tuple[tuple[int, int], ...]
    """(left cone, right cone) of each gate crossed, in order."""
    done: bool = False
    across_m: tuple[float, ...] = ()
    """The track each gate leaves across the path's step through it (m), in order."""


def gate_search_path(
    xy: FloatArray, col: NDArray[np.int64], start_xy_m: FloatArray, start_yaw_rad: float,
    track_width_m: float, behind_m: float = 0.0, driven_xy_m: FloatArray | None = None,
) -> tuple[FloatArray, NDArray[np.bool_]]:
    """The best chain of gates from the car: path points (K, 2) (m, world frame; the first is
    the car, or with ``behind_m`` > 0 the midpoint of the car's gate when it is at most that far
    behind) and a mask (N,) of the cones ``xy`` (N, 2) of colours ``col`` (N,) that bound it
    (but for its last gate's). ``driven_xy_m`` (M, 2): the way the car came (its last tens of
    metres, not the last few): an edge it crossed is never crossed back the other way (without
    colours, the gap between a hairpin's inner end and the next stretch leads back up the way
    in), while the next lap crosses it again the same way.
    K = 1 when there is no gate ahead."""
    start = np.asarray(start_xy_m, np.float64)
    used = np.zeros(len(xy), bool)
    nothing = (start[None, :].copy(), used)
    rel = xy - start
    c, s = math.cos(start_yaw_rad), math.sin(start_yaw_rad)
    ahead = rel[:, 0] * c + rel[:, 1] * s
    near = np.flatnonzero((np.hypot(rel[:, 0], rel[:, 1]) < SEARCH_RADIUS_M) & (ahead > -8.0))
    if len(near) < 3:
        return nothing
    try:
        tri = Delaunay(xy[near])
    except (QhullError, ValueError):
        return nothing
    search = _Search(xy[near], col[near], tri, track_width_m)
    if driven_xy_m is not None and len(driven_xy_m) >= 2:
        driven = np.asarray(driven_xy_m, np.float64)
        crossed = crossings(xy[near], tri.simplices, driven)
        search.behind = {edge: crossing[0] for edge, crossing in crossed.items()}
        if not search.coloured and math.hypot(*(start - driven[-1])) <= ROWS_TO_CAR_M:
            # the rows go on to the car: the cones it passed since the way driven ends (a few
            # metres behind it) are its rows' last, and a row that skips one points off its
            # way on (EUFS Hairpin, camera dead 3 s into the run: a path through the outer
            # row's next two cones)
            crossed = crossings(xy[near], tri.simplices, np.vstack([driven, start[None, :]]))
        search.rows_driven = rows_driven(crossed, xy[near], track_width_m)
    seeds = search.seeds(start, start_yaw_rad, behind_m)
    best = search.run(seeds)
    if best is None or len(best.points) < 2:
        return nothing
    # the last gate's cones stay free: the march beyond pairs them with the next ones
    bounding = sorted({i for gate in best.gates[:-1] for i in gate} - set(best.gates[-1]))
    used[near[bounding]] = True
    points = [np.asarray(best.points[0], np.float64)]
    if best.points[0] != (float(start[0]), float(start[1])):
        points = []  # the path starts at the gate behind the car
    points.extend(_centre_points(xy[near], best.gates, np.asarray(best.points, np.float64)))
    return np.asarray(points, np.float64), used


def coloured_ahead(xy_m: FloatArray, colours: NDArray[np.int64], pose_xy_m: tuple[float, float],
                   yaw_rad: float, reach_m: float) -> bool:
    """Whether at least half the cones ahead of the car (within ``reach_m`` (m) in front and to
    either side; ``xy_m`` (N, 2), ``colours`` (N,)) carry a colour: false with none ahead, and
    once the camera has died, whatever the map kept of the cones seen before."""
    xy = np.asarray(xy_m, np.float64).reshape(-1, 2)
    dx, dy = xy[:, 0] - pose_xy_m[0], xy[:, 1] - pose_xy_m[1]
    c, s = math.cos(yaw_rad), math.sin(yaw_rad)
    along, across = c * dx + s * dy, -s * dx + c * dy
    ahead = (along > 0.0) & (along <= reach_m) & (np.abs(across) <= reach_m)
    if not np.any(ahead):
        return False
    return bool(np.mean(np.asarray(colours)[ahead] != int(ConeColour.UNKNOWN)) >= 0.5)


def has_colours(colours: NDArray[np.int64]) -> bool:
    """Whether any of ``colours`` (N,) is blue or yellow: without, the camera is dead (or has
    not voted yet) and the rows are told apart by their shape alone."""
    return bool(np.any((colours == BLUE) | (colours == YELLOW)))


def cone_in_gate(a_xy_m: FloatArray, b_xy_m: FloatArray, cones_xy_m: FloatArray) -> bool:
    """Whether any of ``cones_xy_m`` (N, 2) stands in the middle of the edge from ``a_xy_m``
    to ``b_xy_m`` (2,) (m): within ``CONE_IN_GATE_FRACTION`` of its length of the edge, on
    either side, abreast of its middle ``CONE_IN_GATE_SPAN``. A gate has the track between
    its cones; an edge with a cone in it spans a boundary (past the end of a row of cones not
    all mapped yet, from one lane across an infield to the next: hard:corner-start; along the
    outer row of a bend wider than a gate: EUFS Hairpin with the camera dead)."""
    edge = np.asarray(b_xy_m, np.float64) - a_xy_m
    length2 = float(edge @ edge)
    if length2 <= 0.0 or len(cones_xy_m) == 0:
        return False
    rel = np.asarray(cones_xy_m, np.float64).reshape(-1, 2) - a_xy_m
    t = (rel @ edge) / length2
    off = np.abs(edge[0] * rel[:, 1] - edge[1] * rel[:, 0]) / math.sqrt(length2)
    inside = (np.abs(t - 0.5) <= 0.5 * CONE_IN_GATE_SPAN) & \
        (off < CONE_IN_GATE_FRACTION * math.sqrt(length2))
    return bool(np.any(inside))


def _centre_points(xy: FloatArray, gates: tuple[tuple[int, int], ...],
                   midpoints: FloatArray) -> list[FloatArray]:
    """One centre point per gate: the first gate's middle, then for each gate the middle
    between the cone it adds and the other side's boundary (its polyline through that side's
    cones in order), in their order along the gates' ``midpoints`` (K, 2) (a cone added late
    may lie abreast of an earlier one: its point is not a step back). A diagonal gate's own
    middle lies off the centre in a bend, and alternating with square gates it would put a
    wiggle into the path's curvature."""
    lefts = list(dict.fromkeys(g[0] for g in gates))
    rights = list(dict.fromkeys(g[1] for g in gates))
    found = [0.5 * (xy[gates[0][0]] + xy[gates[0][1]])]
    seen = {gates[0][0], gates[0][1]}
    for left, right in gates[1:]:
        if left not in seen:
            new, other = left, rights
        elif right not in seen:
            new, other = right, lefts
        else:
            continue
        seen.add(new)
        other_xy = xy[other]
        foot = other_xy[0] if len(other_xy) == 1 else \
            nearest_on_polyline(xy[new][None, :], other_xy, False)[3][0]
        found.append(0.5 * (xy[new] + foot))
    order = np.arange(len(found))
    if len(midpoints) >= 2 and len(found) > 2:
        _, segment, t, _ = nearest_on_polyline(np.asarray(found[1:]), midpoints, False)
        order = np.r_[0, 1 + np.argsort(segment + t, kind="stable")]
    # points within MERGE_M of the first of their run are one point, their mean (a left cone
    # and a right one abreast: one gate, one point). Measured from the run's first point, not
    # from a running mean: round a tight bend with cones 0.7 m apart the points stand 0.4 m
    # apart, and a running mean let a whole bend fall into one point.
    points: list[FloatArray] = []
    run = [found[0]]
    for k in order[1:]:
        point = found[int(k)]
        if math.hypot(*(point - run[0])) < MERGE_M:
            run.append(point)
        else:
            points.append(np.mean(run, axis=0))
            run = [point]
    points.append(np.mean(run, axis=0))
    return points


class _Search:
    """The beam search over one triangulation (cone indices local to it)."""

    def __init__(self, xy: FloatArray, col: NDArray[np.int64], tri: Delaunay,
                 track_width_m: float) -> None:
        self.xy = xy
        self.col = col
        self.simplices: NDArray[np.int32] = tri.simplices
        self.neighbours: NDArray[np.int32] = tri.neighbors
        self.width_m = track_width_m
        self.max_gate_m = MAX_GATE_WIDTHS * track_width_m
        self.max_blind_gate_m = BLIND_GATE_WIDTHS * track_width_m
        self.coloured = has_colours(col)
        self.behind: dict[tuple[int, int], float] = {}
        """Edges (lower index first) the car has driven through, with the side it crossed
        them towards (:func:`planner.gate_rows.edges_crossed`): never a gate back the other way."""
        self.rows_driven: tuple[list[int], list[int]] = ([], [])
        """The cones the way driven passed on its left and on its right, in order
        (:func:`planner.gate_rows.rows_driven`): the rows the path's own gates go on."""

    # -- gates ---------------------------------------------------------------------------
    def _gate_cost(self, a: int, b: int, from_xy: FloatArray
                   ) -> tuple[float, FloatArray, tuple[int, int]] | None:
        """Cost of crossing edge (a, b) from ``from_xy`` towards its midpoint, the midpoint and
        the edge as (left cone, right cone); None when it is not a gate."""
        pa, pb = self.xy[a], self.xy[b]
        length = float(math.hypot(*(pa - pb)))
        if not MIN_GATE_M <= length <= self.max_gate_m:
            return None
        ca, cb = int(self.col[a]), int(self.col[b])
        if ca == cb and ca in (BLUE, YELLOW):
            return None
        if length > self.max_blind_gate_m and ca not in (BLUE, YELLOW) and cb not in (BLUE, YELLOW):
            return None
        mid = 0.5 * (pa + pb)
        d = mid - from_xy
        # which end is on the left of the direction of travel
        side_a = d[0] * (pa[1] - mid[1]) - d[1] * (pa[0] - mid[0])
        left, right = (a, b) if side_a > 0.0 else (b, a)
        if int(self.col[left]) == YELLOW or int(self.col[right]) == BLUE:
            return None
        cost = WIDTH_COST * ((length - self.width_m) / self.width_m) ** 2
        cost += UNKNOWN_COST * sum(x not in (BLUE, YELLOW) for x in (ca, cb))
        return cost, mid, (left, right)

    def _across_m(self, a: int, b: int, yaw_rad: float) -> float:
        """The track edge (a, b) leaves across a path heading ``yaw_rad`` through it (m)."""
        gx, gy = self.xy[b] - self.xy[a]
        return abs(math.cos(yaw_rad) * float(gy) - math.sin(yaw_rad) * float(gx))

    def _continues_the_other_row(self, sides: tuple[int, int],
                                 gates: tuple[tuple[int, int], ...]) -> bool:
        """Whether, in a map without colours, the cone a gate (left, right) ``sides`` adds to
        the path's ``gates`` stands where the other side's row goes on (its next cone, in
        line with the row's last two and about their spacing further) and not where its own
        row goes on. Without colours that edge joins two cones of one boundary: the path
        through it turns out across the boundary (an infield between two stretches of track,
        FSSIM FSI with the camera dead: the search turned into the stretch beside).

        With colours the rows are the colours' and the rule is not applied: a cone of unknown
        colour there is one not voted yet, and with the rule the plans changed near the far
        end of the view enough to move the car by a few centimetres past an inner cone it
        then touched (EUFS Hairpin seed 2, autocross)."""
        if self.coloured:
            return False
        seen = {i for gate in gates for i in gate}
        for new, own, other in ((sides[0], 0, 1), (sides[1], 1, 0)):
            if new in seen:
                continue
            other_row = list(dict.fromkeys([*self.rows_driven[other],
                                            *(g[other] for g in gates)]))
            own_row = list(dict.fromkeys([*self.rows_driven[own], *(g[own] for g in gates)]))
            return (in_line(self.xy, other_row, new, ROW_TOLERANCE)
                    and not in_line(self.xy, own_row, new, OWN_ROW_TOLERANCE))
        return False

    def _joins_one_row(self, sides: tuple[int, int], gates: tuple[tuple[int, int], ...]
                       ) -> bool:
        """Whether, with colours, a gate (left, right) ``sides`` joins the cone of known
        colour that ends its side's row (the path's gates so far; the way driven before them
        when they give one cone) to a cone of unknown colour further on along that row's
        line, at any distance a gate spans (:func:`planner.gate_rows.in_line`): two cones of
        one boundary, the second not coloured yet, as blue-blue and yellow-yellow edges are.
        A coloured lane ending at 60 m with one uncoloured cone 6-9 m beyond, on its left
        row's line, had the path end on that line, outside the lane; on EUFS Hairpin
        (autocross) a yellow row's next cone, mapped 0.5 s before its colour, made a gate
        with the row's last one and a path across the row. (The way driven goes on a row
        only when the gates give one cone of it: round a hairpin's end it bends the row's
        way on away from the row's next cone.)"""
        if not self.coloured:
            return False
        for known, unknown, side in ((sides[0], sides[1], 0), (sides[1], sides[0], 1)):
            if int(self.col[known]) not in (BLUE, YELLOW) or \
                    int(self.col[unknown]) in (BLUE, YELLOW):
                continue
            row = list(dict.fromkeys(g[side] for g in gates))
            if len(row) < 2:  # the car's own gate alone: the row it drove along before it
                row = list(dict.fromkeys([*self.rows_driven[side], *row]))
            if row and row[-1] == known and \
                    in_line(self.xy, row, unknown, ROW_TOLERANCE, self.max_gate_m):
                return True
        return False

    def _back_the_way_in(self, a: int, b: int, step: FloatArray) -> bool:
        """Whether a step (2,) through edge (a, b) crosses it against the way the car drove
        through it (the next lap crosses it the same way: that is no way back)."""
        lo, hi = min(a, b), max(a, b)
        side = self.behind.get((lo, hi))
        if side is None:
            return False
        edge = self.xy[hi] - self.xy[lo]
        return float(edge[0] * step[1] - edge[1] * step[0]) * side < 0.0

    def _containing_triangle(self, point: FloatArray) -> int:
        """Index of the triangle that contains ``point`` (2,), -1 for none (the same sign
        test on all three edges; Delaunay.find_simplex computes barycentric transforms with
        LAPACK, which a multithreaded BLAS on a busy machine made take seconds)."""
        v = self.xy[self.simplices]  # (T, 3, 2)
        e = np.roll(v, -1, axis=1) - v
        r = point[None, None, :] - v
        cross = e[:, :, 0] * r[:, :, 1] - e[:, :, 1] * r[:, :, 0]
        inside = np.all(cross >= 0.0, axis=1) | np.all(cross <= 0.0, axis=1)
        hits = np.flatnonzero(inside)
        return int(hits[0]) if len(hits) else -1

    # -- seeds ---------------------------------------------------------------------------
    def _entry_gate(self, tri: NDArray[np.int64], start: FloatArray, yaw: float, behind_m: float
                    ) -> tuple[tuple[int, int], FloatArray, tuple[int, int]] | None:
        """The gate the car came through into its triangle ``tri`` (3,): the edge a line back
        from the car along its heading leaves the triangle by, when that edge is a gate whose
        midpoint is at most ``behind_m`` behind the car (and less than ``ENTRY_AHEAD_M``
        ahead: a gate across the track at a slant). Returns the edge, its midpoint and its
        (left, right) cones; None when there is none. The path then starts at it, so a car off
        the middle sees its offset instead of a path through itself, whichever triangle it
        is in (the nearest gate behind by its midpoint can be the one ahead, at a slant)."""
        heading = np.array([math.cos(yaw), math.sin(yaw)])
        best_t, edge = math.inf, None
        for k in range(3):
            a, b = int(tri[(k + 1) % 3]), int(tri[(k + 2) % 3])
            pa, along = self.xy[a], self.xy[b] - self.xy[a]
            # start - t * heading = pa + u * along, solved for (t, u)
            det = float(along[0] * heading[1] - along[1] * heading[0])
            if abs(det) < 1e-12:
                continue
            rel = start - pa
            t = float(along[0] * rel[1] - along[1] * rel[0]) / det
            u = float(rel[0] * heading[1] - rel[1] * heading[0]) / det
            if 0.0 <= u <= 1.0 and 0.0 <= t < best_t:
                best_t, edge = t, (a, b)
        if edge is None:
            return None
        a, b = edge
        # crossed along the car's heading (from a point behind the car, a gate beside it
        # would be crossed sideways and its sides swap)
        gate = self._gate_cost(a, b, 0.5 * (self.xy[a] + self.xy[b]) - heading)
        if gate is None or self._across_m(a, b, yaw) < MIN_ACROSS_M:
            return None
        mid = gate[1]
        ahead = float((mid - start) @ heading)
        if not -behind_m <= ahead < ENTRY_AHEAD_M:
            return None
        return (a, b), mid, gate[2]

    def seeds(self, start: FloatArray, yaw: float, behind_m: float) -> list[_Partial]:
        """The search's first partial paths: in the car's triangle (entered by its edge behind
        the car), or through the gates ahead of a car outside the triangulation."""
        c, s = math.cos(yaw), math.sin(yaw)
        t0 = self._containing_triangle(start)
        out: list[_Partial] = []
        origin = (float(start[0]), float(start[1]))
        if t0 >= 0:
            tri = self.simplices[t0]
            entry = self._entry_gate(tri, start, yaw, behind_m) if behind_m > 0.0 else None
            if entry is not None:
                (a, b), mid, sides = entry
                out.append(_Partial(((float(mid[0]), float(mid[1])),), t0, (a, b), yaw, 0.0,
                                    frozenset([t0]), (sides,),
                                    across_m=(self._across_m(a, b, yaw),)))
            else:
                out.append(_Partial((origin,), t0, (-1, -1), yaw, 0.0, frozenset([t0]), ()))
            return out
        for t, tri in enumerate(self.simplices):
            for k in range(3):
                # edges ahead that face the car: the triangle beyond lies on their far side
                a, b = int(tri[(k + 1) % 3]), int(tri[(k + 2) % 3])
                pa, pb, pc = self.xy[a], self.xy[b], self.xy[int(tri[k])]
                edge = pb - pa
                car_side = edge[0] * (start[1] - pa[1]) - edge[1] * (start[0] - pa[0])
                far_side = edge[0] * (pc[1] - pa[1]) - edge[1] * (pc[0] - pa[0])
                if car_side * far_side >= 0.0:
                    continue
                gate = self._gate_cost(a, b, start)
                if gate is None or (not self.coloured and cone_in_gate(
                        self.xy[a], self.xy[b], self.xy[[int(tri[k])]])):
                    continue
                cost, mid, sides = gate
                rel = mid - start
                ahead = float(rel[0] * c + rel[1] * s)
                lateral = float(-rel[0] * s + rel[1] * c)
                if not 0.3 < ahead < 10.0 or abs(lateral) > self.width_m:
                    continue
                step_yaw = math.atan2(rel[1], rel[0])
                turn = abs(math.remainder(step_yaw - yaw, 2.0 * math.pi))
                across = self._across_m(a, b, step_yaw)
                if turn > MAX_TURN_RAD or across < MIN_ACROSS_M:
                    continue
                out.append(_Partial(
                    (origin, (float(mid[0]), float(mid[1]))), t, (a, b), step_yaw,
                    cost + TURN_COST_PER_RAD2 * turn ** 2, frozenset([t]), (sides,),
                    across_m=(across,)))
        # the way to the first gate earns nothing, and a path that starts at a gate further on
        # than the nearest pays for the way it skips (it would save the nearer gates' costs)
        reach = [math.hypot(p.points[1][0] - origin[0], p.points[1][1] - origin[1]) for p in out]
        nearest = min(reach, default=0.0)
        return [replace(p, cost=p.cost + SKIP_COST_PER_M * (r - nearest))
                for p, r in zip(out, reach, strict=True)]

    # -- search --------------------------------------------------------------------------
    def _expand(self, p: _Partial) -> list[_Partial]:
        tri = [int(v) for v in self.simplices[p.triangle]]
        here = np.asarray(p.points[-1], np.float64)
        out = []
        for k in range(3):
            a, b = tri[(k + 1) % 3], tri[(k + 2) % 3]
            if {a, b} == set(p.entry):
                continue
            gate = self._gate_cost(a, b, here)
            if gate is None:
                continue
            cost, mid, sides = gate
            if any(sides[0] == g[1] or sides[1] == g[0] for g in p.gates):
                continue  # a cone keeps its side: no gate along a boundary
            step = mid - here
            length = float(math.hypot(*step))
            step_yaw = math.atan2(step[1], step[0]) if length > 0.3 else p.yaw_rad
            turn = abs(math.remainder(step_yaw - p.yaw_rad, 2.0 * math.pi))
            if turn > MAX_TURN_RAD:
                continue
            across = self._across_m(a, b, step_yaw)
            if across < MIN_ACROSS_M:
                continue  # crossed so obliquely that it leaves no track width: a boundary
            if len(p.across_m) >= 2 and across < LANE_NARROWING * float(np.median(p.across_m)):
                continue  # the lane narrows to a fraction of itself: along a boundary
            nxt = int(self.neighbours[p.triangle][k])
            # the third corner of the path's triangle, and without colours the one beyond the
            # edge too (with colours a cone there is one in the lane, the manoeuvres' to clear)
            corners = [tri[k]]
            if nxt != -1 and not self.coloured:
                corners += [int(v) for v in self.simplices[nxt] if int(v) not in (a, b)]
            if cone_in_gate(self.xy[a], self.xy[b], self.xy[corners]):
                continue  # it spans a boundary (a cone stands in it): two lanes, not one
            if self._continues_the_other_row(sides, p.gates):
                continue  # the cone it adds is the next of the other side's row
            if self._joins_one_row(sides, p.gates):
                continue  # a row's last cone and one further on it, not coloured yet
            if self._back_the_way_in(a, b, step):
                continue
            if nxt in p.triangles:
                continue
            out.append(_Partial(
                p.points + ((float(mid[0]), float(mid[1])),), nxt, (a, b), step_yaw,
                p.cost + cost + TURN_COST_PER_RAD2 * turn ** 2 - LENGTH_REWARD_PER_M * length,
                p.triangles | {nxt}, p.gates + (sides,), done=nxt == -1,
                across_m=p.across_m + (across,)))
        return out

    def run(self, seeds: list[_Partial]) -> _Partial | None:
        """The path found that reaches furthest through valid gates, the straightest and
        best-gated among those."""
        frontier = [p for p in seeds if not p.done]
        finished = list(seeds)
        for _ in range(MAX_DEPTH):
            children: list[_Partial] = []
            for p in frontier:
                kids = self._expand(p)
                children.extend(kids)
                if not kids:
                    finished.append(p)
            if not children:
                break
            children.sort(key=lambda q: q.cost)
            frontier = [q for q in children[:BEAM] if not q.done]
            finished.extend(q for q in children[:BEAM] if q.done)
        finished.extend(frontier)
        if not finished:
            return None
        # reach first: through a hairpin every gate's turn costs more than its length earns,
        # and the path that stops before the bend must not be the best
        return min(finished, key=lambda q: q.cost - REACH_REWARD_PER_GATE * len(q.gates))
