"""The rows of cones a gate search tells apart (:mod:`planner.gate_search`): which edges of the
cones' triangulation a way driven crossed and the cones it so passed on either hand, in order,
and where a row of cones goes on beyond its last cone.

Without colours these are a lane's sides: two cones of one row make no gate, and a cone that
stands where the other side's row goes on is no cone of this side. With colours they tell a
row's next cone, not coloured yet, from a cone across the lane.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]


def edges_crossed(xy: FloatArray, simplices: NDArray[np.int32],
                  path_xy: FloatArray) -> dict[tuple[int, int], float]:
    """The triangulation's edges (index pairs, lower first) that the polyline ``path_xy``
    (M, 2) crosses, each with the side it crossed it towards: the sign of the cross product of
    the edge (lower index to higher) and the path's step (its last crossing's, if several)."""
    return {edge: crossing[0] for edge, crossing in crossings(xy, simplices, path_xy).items()}


def crossings(xy: FloatArray, simplices: NDArray[np.int32],
              path_xy: FloatArray) -> dict[tuple[int, int], tuple[float, float, float]]:
    """:func:`edges_crossed`, each edge with the side, where along ``path_xy`` (its segment
    index plus the fraction of that segment) the path last crossed it, and where along the
    edge (the fraction of it from its lower cone)."""
    edges = np.unique(np.sort(np.concatenate([simplices[:, [0, 1]], simplices[:, [1, 2]],
                                              simplices[:, [2, 0]]]), axis=1), axis=0)
    p, r = xy[edges[:, 0]][:, None, :], (xy[edges[:, 1]] - xy[edges[:, 0]])[:, None, :]
    q, u = path_xy[None, :-1, :], np.diff(path_xy, axis=0)[None, :, :]

    def cross(v: FloatArray, w: FloatArray) -> FloatArray:
        return np.asarray(v[..., 0] * w[..., 1] - v[..., 1] * w[..., 0], np.float64)

    denom = cross(r, u)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = cross(q - p, u) / denom  # along the edge
        v = cross(q - p, r) / denom  # along the path's segment
    hit = (np.abs(denom) > 1e-12) & (t >= 0.0) & (t <= 1.0) & (v >= 0.0) & (v <= 1.0)
    out: dict[tuple[int, int], tuple[float, float, float]] = {}
    for e in np.flatnonzero(np.any(hit, axis=1)):
        last = int(np.flatnonzero(hit[e])[-1])
        out[(int(edges[e, 0]), int(edges[e, 1]))] = (
            float(np.sign(denom[e, last])), last + float(v[e, last]), float(t[e, last]))
    return out


def rows_driven(crossed: dict[tuple[int, int], tuple[float, float, float]], xy: FloatArray,
                aside_m: float) -> tuple[list[int], list[int]]:
    """The cones the way driven passed on its left and on its right (index lists, in the
    order it passed them), from the edges it crossed (:func:`crossings`) among the cones
    ``xy`` (N, 2): a step that crosses an edge (lower index to higher) towards its positive
    side has the lower cone on its left. Only a cone at most ``aside_m`` (m) from where the
    way crossed counts (a long edge to the row beyond a 3 m infield is crossed too, and its
    far cone is no cone of the lane). A cone passed on both sides (a path that wandered)
    counts where last passed."""
    last: dict[int, tuple[float, int]] = {}
    for (lo, hi), (side, where, t) in crossed.items():
        length = float(math.hypot(*(xy[hi] - xy[lo])))
        left, right = (lo, hi) if side > 0.0 else (hi, lo)
        for cone, on_left in ((left, 1), (right, 0)):
            aside = t * length if cone == lo else (1.0 - t) * length
            if aside <= aside_m and (cone not in last or last[cone][0] < where):
                last[cone] = (where, on_left)
    ordered = sorted(last, key=lambda i: last[i][0])
    return ([i for i in ordered if last[i][1] == 1], [i for i in ordered if last[i][1] == 0])


def in_line(xy: FloatArray, row: list[int], new: int, tolerance: float,
            furthest_m: float | None = None) -> bool:
    """Whether cone ``new`` stands where ``row`` (indices into the cones ``xy`` (N, 2), in
    order) goes on: beyond its last cone, between half and 1.5 times the last spacing (plus
    half a metre) further, off the row's way on by at most ``tolerance`` times how far on it
    stands.
    The way on is the line through the row's last two cones turned by its last turn (the
    turn from its last but one step to its last: a row round a bend keeps turning; the
    outer row of a rules-minimum hairpin turns 30 degrees a cone, and the inner row's
    chord, straight on, meets it).

    With ``furthest_m``, also a cone further on, up to that far, when the row runs
    straight (its last turn within the tolerance) and the cone stands on its line, as
    near it as above: a row's next cone but one, or further. A row's way on turned by a
    bend's turn says nothing that far (FSSIM thin: a yellow row turning 56 degrees into a
    bend pointed 4.8 m on at the blue row's next cone)."""
    if len(row) < 2:
        return False
    last, before = xy[row[-1]], xy[row[-2]]
    direction = last - before
    spacing = float(math.hypot(*direction))
    if spacing <= 0.0:
        return False
    straight = math.atan2(direction[1], direction[0])
    turn = 0.0
    if len(row) >= 3:
        earlier = before - xy[row[-3]]
        turn = math.remainder(straight - math.atan2(earlier[1], earlier[0]), 2.0 * math.pi)
    rel = xy[new] - last

    def along_off(heading: float) -> tuple[float, float]:
        return (float(rel[0] * math.cos(heading) + rel[1] * math.sin(heading)),
                abs(float(-rel[0] * math.sin(heading) + rel[1] * math.cos(heading))))

    next_m = 1.5 * spacing + 0.5
    along, off = along_off(straight + turn)
    if 0.5 * spacing <= along <= next_m and off <= tolerance * along:
        return True
    if furthest_m is None or abs(turn) > math.atan(tolerance):
        return False
    along, off = along_off(straight)
    return next_m < along <= furthest_m and off <= tolerance * along
