"""The path ahead through an unseen track, from the cones mapped so far (autonomous exploration).

First the chain of gates a search over the cones' Delaunay triangulation finds from the car
(:mod:`planner.gate_search`): it never crosses a boundary to reach a cone of another stretch
of track. Where it ends (one side not seen yet, a corner hides it), gate marching goes on,
after FaSTTUBe's ft-fsd-path-planning in spirit (written here from scratch): from the last
point, look ahead along the current heading for the nearest cone on each side of the track
(blue on the left, yellow on the right; a cone of unknown or orange colour on the side it lies);
the next path point is the middle of that gate, or half a nominal track width inside a cone
when the other side is not seen. Step to it, turn, repeat until no cone is ahead. Cones used
for a gate are not used again; a cone far beside the path (more than a track width) is not a
boundary. The path ends where the known track ends: the speed profile brakes to a stop there,
so the car never outruns what it has seen.

In a map without colours (the camera dead) the march ends at a gate of one cone: which side
that cone bounds is only a guess from where it lies against the heading, and past the end of
the triangulation's gates (a bend, one side not seen) the guess is wrong as often as not; half
a track width on the wrong side of the cone puts the path's end across the boundary (`bench
plan_local` without colours: peanut 0.18 of the paths inside, 1.0 with the rule). With colours
a lone cone of unknown colour is one not voted yet among coloured ones, and the march goes on
as before (ending there took the car wide out of a hairpin: hard:hairpins hit a cone in every
seed).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial import cKDTree

from common.messages import ConeColour
from planner.gate_search import ENTRY_AHEAD_M, cone_in_gate, gate_search_path, has_colours

FloatArray = NDArray[np.float64]

BLUE, YELLOW = int(ConeColour.BLUE), int(ConeColour.YELLOW)
UNKNOWN = int(ConeColour.UNKNOWN)

SAME_CONE_M = 0.25
"""Two landmarks nearer than this (m) are one cone: cones stand further apart."""

OWN_COLOUR_REACH_M = 3.0
"""A cone of the side's own colour is taken over a nearer one of unknown colour (a stray
cone) when it is at most this much (m) further; further on it is the boundary's next cone and
the nearer one the boundary's, its colour not yet voted (the first cones seen at the start)."""

ENTRY_BEHIND_M = 6.0
"""How far behind the car (m) the gate it came through may be for the exploring path to
start there (the planner's ``behind_m``): beyond the rules' longest cone spacing (5 m), so the
path starts at that gate wherever the car is in its triangle, not at the gate in one plan and
at the car, off the middle, in the next (at 2.5 m: FSSIM thin autocross seed 3)."""

MIN_STEP_M = 1.5
"""A gate nearer than this ahead of the last point (m) is passed, not stepped to."""


def exploration_path(
    cones_xy_m: ArrayLike,
    colours: ArrayLike,
    start_xy_m: tuple[float, float],
    start_yaw_rad: float,
    *,
    track_width_m: float = 3.5,
    look_ahead_m: float = 9.0,
    max_turn_rad: float = 1.0,
    max_points: int = 40,
    behind_m: float = 0.0,
    driven_xy_m: FloatArray | None = None,
) -> FloatArray:
    """Path points (K, 2) (m, world frame) from the car at ``start_xy_m`` heading
    ``start_yaw_rad`` through the gates of ``cones_xy_m`` (N, 2) with their
    :class:`ConeColour` (N,). K = 1 (the start alone) when no gate is ahead.

    ``look_ahead_m``: how far ahead of the last point a gate's cones may be; ``max_turn_rad``:
    the largest heading change from one point to the next (a sharper one is a cone of another
    stretch of track, not the next gate). ``behind_m`` > 0: the first gate may be up to that far
    behind the start, and the path then begins at it instead of at the start (a car that has
    drifted from the middle of the track sees the offset instead of a path through itself).
    ``driven_xy_m`` (M, 2): the way the car came, whose gates the search never takes again
    (:func:`planner.gate_search.gate_search_path`).
    """
    xy = np.asarray(cones_xy_m, np.float64).reshape(-1, 2)
    col = np.asarray(colours, np.int64).reshape(-1)
    keep = np.all(np.isfinite(xy), axis=1)
    xy, col = _one_per_cone(xy[keep], col[keep])
    point = np.asarray(start_xy_m, np.float64)
    yaw = float(start_yaw_rad)
    points = [point.copy()]
    unused = np.ones(len(xy), bool)
    searched, bounding = gate_search_path(xy, col, point, yaw, track_width_m, behind_m,
                                          driven_xy_m)
    if len(searched) >= 3:
        # the triangulation's gates as far as both sides are known; marched on beyond
        points = [p.copy() for p in searched]
        point = searched[-1].copy()
        step = searched[-1] - searched[-2]
        yaw = math.atan2(step[1], step[0])
        unused &= ~bounding
        behind_m = -0.3
    half = 0.5 * track_width_m
    colour_blind = not has_colours(col)
    for k in range(max_points - len(points) + 1):
        gate = _next_gate(xy, col, unused, point, yaw, look_ahead_m, track_width_m,
                          behind_m if k == 0 else -0.3)
        if gate is None:
            break
        left, right = gate
        if colour_blind and (left is None or right is None):
            break  # one cone and no colours: which side it bounds is a guess
        if colour_blind and left is not None and right is not None and cone_in_gate(
                xy[left], xy[right], np.delete(xy, [left, right], axis=0)):
            break  # a cone stands in it: no colours say it is no boundary beside the path
        c, s = math.cos(yaw), math.sin(yaw)
        to_left = np.array([-s, c])
        if left is not None and right is not None:
            target = 0.5 * (xy[left] + xy[right])
        elif left is not None:
            target = xy[left] - half * _inward(xy, col, left, point, to_left)
        else:
            assert right is not None
            target = xy[right] + half * _inward(xy, col, right, point, to_left)
        for i in (left, right):
            if i is not None:
                unused[i] = False
        step = target - point
        if k == 0 and behind_m > 0.0 and float(step @ np.array([c, s])) < ENTRY_AHEAD_M:
            points = [target.copy()]  # the path starts at the gate beside the car
            point = target
            continue
        if float(step @ np.array([c, s])) < MIN_STEP_M:
            continue  # a gate at the car's side: too near to say which way the track goes
        new_yaw = math.atan2(step[1], step[0])
        if abs(math.remainder(new_yaw - yaw, 2.0 * math.pi)) > max_turn_rad:
            break
        point, yaw = target, new_yaw
        points.append(point.copy())
    return np.asarray(points, np.float64)


def _one_per_cone(xy: FloatArray, col: NDArray[np.int64]) -> tuple[FloatArray, NDArray[np.int64]]:
    """One point per physical cone: landmarks nearer than ``SAME_CONE_M`` to another are the
    same cone mapped twice (before the loop closes, the SLAM does not associate a cone it saw
    long ago: seed 000 5.3.2; across a narrow part of the track it sees it again). The one of a
    known colour is kept."""
    if len(xy) < 2:
        return xy, col
    pairs = cKDTree(xy).query_pairs(SAME_CONE_M, output_type="ndarray")
    if not len(pairs):
        return xy, col
    drop = np.zeros(len(xy), bool)
    for i, j in pairs:
        if drop[i] or drop[j]:
            continue
        drop[i if col[i] == UNKNOWN and col[j] != UNKNOWN else j] = True
    return xy[~drop], col[~drop]


def _next_gate(
    xy: FloatArray, col: NDArray[np.int64], unused: NDArray[np.bool_], point: FloatArray,
    yaw: float, look_ahead_m: float, track_width_m: float, behind_m: float = -0.3,
) -> tuple[int | None, int | None] | None:
    """Indices of the nearest cone ahead on the left and on the right (either may be None);
    None when neither side has one."""
    if not unused.any():
        return None
    c, s = math.cos(yaw), math.sin(yaw)
    rel = xy - point
    ahead = rel[:, 0] * c + rel[:, 1] * s
    lateral = -rel[:, 0] * s + rel[:, 1] * c
    distance = np.hypot(ahead, lateral)
    left = right = None
    # the cones within a track width to the side; a side that has none there is looked for a
    # half width further (in a bend the far side's next cone lies wide of the heading)
    for reach_m in (track_width_m, 1.5 * track_width_m):
        near = unused & (ahead > -behind_m) & (ahead < look_ahead_m) & (np.abs(lateral) < reach_m)
        if left is None:
            left = _nearest(near & ((col == BLUE) | ((col != YELLOW) & (lateral > 0.0))),
                            col == BLUE, distance)
        if right is None:
            right = _nearest(near & ((col == YELLOW) | ((col != BLUE) & (lateral <= 0.0))),
                             col == YELLOW, distance)
    if left is None and right is None:
        return None
    if left is not None and right is not None:
        gap = xy[left] - xy[right]
        width = float(np.hypot(*gap))
        along = abs(float(gap[0] * c + gap[1] * s))
        across = abs(float(-gap[0] * s + gap[1] * c))
        # not one gate (too wide, or one side's cone is missing and the other side's next one
        # pairs with it diagonally): keep the nearer cone
        if width > 2.0 * track_width_m or along > 0.8 * across:
            if distance[left] <= distance[right]:
                right = None
            else:
                left = None
    return left, right


def _nearest(candidates: NDArray[np.bool_], own_colour: NDArray[np.bool_],
             distance: FloatArray) -> int | None:
    """Index of the nearest candidate, one of the side's own colour before a nearer one of
    unknown colour (a stray cone); None when there is no candidate."""
    if not candidates.any():
        return None
    nearest = int(np.argmin(np.where(candidates, distance, np.inf)))
    own = candidates & own_colour
    if own.any():
        nearest_own = int(np.argmin(np.where(own, distance, np.inf)))
        # ... unless the side's own colour is only further on (its next cone, past the
        # nearest one whose colour is not known yet)
        if distance[nearest_own] <= distance[nearest] + OWN_COLOUR_REACH_M:
            return nearest_own
    return nearest


def _inward(xy: FloatArray, col: NDArray[np.int64], i: int, point: FloatArray,
            to_left: FloatArray) -> FloatArray:
    """The unit normal of the boundary at cone ``i`` pointing left of the direction of travel:
    from the line to its nearest neighbour of the same colour (of the same side for a cone of
    unknown colour), run away from ``point``; ``to_left`` (the car's left) when it has none
    within 8 m."""
    same = col == col[i]
    if col[i] not in (BLUE, YELLOW):
        # a cone of unknown colour: its neighbours on the same side of the path, not across
        side = (xy - point) @ to_left
        same &= np.sign(side) == np.sign(side[i])
    same = np.flatnonzero(same)
    same = same[same != i]
    if len(same):
        d = np.hypot(*(xy[same] - xy[i]).T)
        j = int(same[np.argmin(d)])
        if float(np.min(d)) < 8.0:
            tangent = (xy[j] - xy[i]) / max(float(np.hypot(*(xy[j] - xy[i]))), 1e-9)
            forward = np.array([to_left[1], -to_left[0]])
            along = float(tangent @ forward)
            if abs(along) > 0.3:
                tangent = tangent if along > 0.0 else -tangent
            elif np.hypot(*(xy[i] - point)) < np.hypot(*(xy[j] - point)):
                # the boundary runs across the heading (deep in a bend): it runs on from the
                # nearer of the two cones to the further
                pass
            else:
                tangent = -tangent
            return np.array([-tangent[1], tangent[0]])
    return to_left
