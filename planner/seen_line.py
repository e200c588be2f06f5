"""A racing line through the cones seen so far, for the unseen lap (issue 45).

The path through the gates seen (:mod:`planner.exploration_path`) runs through the middles of
the gates: in a bend it is as curved as the track's middle, where a racing line would swing
wide, clip the inside and swing wide again. Where the lane has room for it, the exploring
frame is instead the least curved line (:func:`planner.racing_line.min_curvature_offsets_ls`)
within the part of the lane in which the path keeps ``room_m`` of room
(:func:`planner.exploration_speed.passage_room_m`, the manoeuvres' circles and full margin):
the exploring profile then still plans with its wide-room share of the lateral limit there, on
a line that bends less. Where the lane has less than that room, and beyond the last metres in
which both of its sides have been seen, the line is the gates' path itself: where the track
goes on is not known, and the line ends on the middle of the lane.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from planner.baseframe import SplineBaseframe
from planner.config import PlannerConfig
from planner.exploration_speed import free_sides_m
from planner.racing_line import min_curvature_offsets_ls

FloatArray = NDArray[np.float64]

LINE_STEP_M = 1.5
"""Spacing (m) of the line's samples while it is solved for."""
GAUSS_NEWTON_STEPS = 1
"""Linearised solves of the line: on a bend's 31 samples a second and third took the sum of
squared curvatures from 0.16614 to 0.16598 (0.1 %)."""
FINE_STEP_M = 0.5
"""Spacing (m) of the points whose room bounds the line's samples."""
HOLD_AHEAD_M = 3.0
"""How far (m) ahead of the car the line is held where the last plan's frame ran."""
HOLD_MAX_M = 1.5
"""A sample further (m) than this from the last plan's frame is not held to it."""
NEAR_START_M = 12.0
"""The stretch (m) of a frame from its start, and about the car, that the car and the line
near it are projected onto (a frame starts at most 6 m behind the car)."""
SIDE_REACH_M = 4.0
"""How far (m) beside the path a cone bounds its side; a side with no cone within this is not
seen there."""


def seen_racing_frame(frame: SplineBaseframe, cones_xy_m: FloatArray,
                      circle_offsets_m: ArrayLike, required_m: float, room_m: float,
                      config: PlannerConfig, car_xy_m: tuple[float, float] | None = None,
                      previous: SplineBaseframe | None = None) -> SplineBaseframe | None:
    """The open exploring ``frame`` moved to the least curved line that keeps ``room_m`` (m)
    of room among the cones ``cones_xy_m`` (N, 2) (body circles at ``circle_offsets_m`` along
    the heading, ``required_m`` from a cone centre), as a new frame; None when it moves
    nowhere by more than a centimetre, or is too short to solve.

    With the car at ``car_xy_m`` (m) and the ``previous`` plan's open frame, the line up to
    :data:`HOLD_AHEAD_M` ahead of the car is held where that frame ran: the line is solved
    afresh only beyond, so the car's offset from it does not jump between plans."""
    if frame.closed or len(cones_xy_m) == 0:
        return None
    every = max(int(round(LINE_STEP_M / frame.step_m)), 1)
    idx = np.arange(0, len(frame.s_m), every)
    if idx[-1] != len(frame.s_m) - 1:  # the frame's end too: the track seen ends there
        idx = np.append(idx, len(frame.s_m) - 1)
    xy = frame.xy_m[idx]
    heading = frame.heading_rad[idx]
    s = frame.s_m[idx]
    if len(xy) < 6:
        return None
    left, right, blocked = _free_sides_between(frame, idx, every, cones_xy_m, circle_offsets_m,
                                               required_m)
    half = 0.5 * room_m
    upper = left - half
    lower = -(right - half)
    seen_to_m = _both_sides_seen_to_m(frame, cones_xy_m)
    pinned = blocked | (lower > upper) | (s >= seen_to_m)
    pinned[-1] = True
    upper = np.maximum(upper, 0.0)
    lower = np.minimum(lower, 0.0)
    upper[pinned] = 0.0
    lower[pinned] = 0.0
    if car_xy_m is not None and previous is not None and not previous.closed:
        held, offset = _held_offsets(frame, previous, xy, s, car_xy_m)
        upper[held] = offset[held]
        lower[held] = offset[held]
    if not np.any(upper - lower > 0.01):
        return None
    normals = np.stack([-np.sin(heading), np.cos(heading)], axis=1)
    offsets = min_curvature_offsets_ls(xy, normals, lower, upper, closed=False,
                                       iterations=GAUSS_NEWTON_STEPS)
    if np.max(np.abs(offsets)) < 0.01:
        return None
    line = xy + offsets[:, None] * normals
    return SplineBaseframe(line, False, resample_m=config.baseframe_resample_m,
                           smoothing_m=config.racing_line_smoothing_m,
                           step_m=config.baseframe_step_m)


def _free_sides_between(frame: SplineBaseframe, idx: NDArray[np.int64], every: int,
                        cones_xy_m: FloatArray, circle_offsets_m: ArrayLike, required_m: float
                        ) -> tuple[FloatArray, FloatArray, NDArray[np.bool_]]:
    """:func:`planner.exploration_speed.free_sides_m` at the samples ``idx`` of ``frame``
    (``every`` apart), each the least over the frame's points up to the samples either side
    (the line runs between its samples, past cones abreast of neither)."""
    from scipy.ndimage import maximum_filter1d, minimum_filter1d  # local: only this needs it

    stride = max(int(round(FINE_STEP_M / frame.step_m)), 1)
    fine_xy = frame.xy_m[::stride]
    left, right, blocked = free_sides_m(fine_xy, frame.heading_rad[::stride], cones_xy_m,
                                        circle_offsets_m, required_m, SIDE_REACH_M)
    size = 2 * max(int(round(every / stride)), 1) + 1
    pick = np.minimum(idx // stride, len(fine_xy) - 1)
    return (minimum_filter1d(left, size, mode="nearest")[pick],
            minimum_filter1d(right, size, mode="nearest")[pick],
            maximum_filter1d(blocked.astype(np.uint8), size, mode="nearest")[pick] > 0)


def _held_offsets(frame: SplineBaseframe, previous: SplineBaseframe, xy: FloatArray,
                  s: FloatArray, car_xy_m: tuple[float, float]
                  ) -> tuple[NDArray[np.bool_], FloatArray]:
    """Which samples (M,) of ``frame`` (points ``xy`` (M, 2) at arc lengths ``s`` (M,)) lie no
    further than :data:`HOLD_AHEAD_M` ahead of the car, within ``previous``'s length and
    :data:`HOLD_MAX_M` of it; and the offsets (M,) (m) that put them on ``previous``.

    Both frames start at a gate behind the car; once the cones seen go round the track, a
    frame's far end comes back near its start, so the car and the samples are projected onto
    the stretch of each frame that starts there (within :data:`NEAR_START_M` of the start)."""
    s_car = frame.project(*car_xy_m, s_hint_m=float(frame.s_m[0]), window_m=NEAR_START_M)[0]
    s_hint = previous.project(*car_xy_m, s_hint_m=float(previous.s_m[0]),
                              window_m=NEAR_START_M)[0]
    held = np.zeros(len(s), bool)
    offset = np.zeros(len(s))
    for i in np.nonzero(s <= s_car + HOLD_AHEAD_M)[0]:
        s_prev, d_prev = previous.project(float(xy[i, 0]), float(xy[i, 1]), s_hint_m=s_hint,
                                          window_m=NEAR_START_M)
        inside = previous.s_m[0] < s_prev < previous.s_m[-1]
        held[i] = inside and abs(d_prev) <= HOLD_MAX_M
        offset[i] = -d_prev
    return held, offset


def _both_sides_seen_to_m(frame: SplineBaseframe, cones_xy_m: FloatArray) -> float:
    """The arc length (m) along ``frame`` up to which both sides have a cone within
    :data:`SIDE_REACH_M` (the further cone of each side, the nearer of the two)."""
    cones = np.asarray(cones_xy_m, np.float64).reshape(-1, 2)
    s, d = frame.project_many(cones)
    near = (np.abs(d) <= SIDE_REACH_M) & (s > frame.s_m[0]) & (s < frame.s_m[-1])
    left_s = s[near & (d > 0.0)]
    right_s = s[near & (d < 0.0)]
    if len(left_s) == 0 or len(right_s) == 0:
        return -np.inf
    return float(min(left_s.max(), right_s.max()))
