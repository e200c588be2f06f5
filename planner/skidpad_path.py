"""The skidpad event's path: the figure of eight fitted to the mapped circles' cones.

The rules' layout (FS Rules D4): two circles side by side, 15.25 m inner diameter, a 3 m lane,
their centres 18.25 m apart, meeting at a gate of big orange cones (the timing line) on the
straight from the entry lane to the exit lane. The car enters, drives two laps of the right
circle (clockwise), two of the left (counter-clockwise), and leaves through the exit lane; the
second lap of each side is timed.

The path: the gate's big orange cones give a first guess of the crossing (the middle of the
eight) and the car's heading of the axis; each circle's centre is then fitted to the cones
mapped on its side, each cone on the ring (inner or outer, the rules' radii) it lies nearest.
The crossing is the middle of the two centres; the path runs around each circle in the middle
of its lane, from and back to its point nearest the crossing. Until the
gate is mapped the path is only the entry straight as far as cones are known (``complete``
False), stopping at its end: the builder is asked again as the map grows.
"""

from __future__ import annotations

import logging
import math

import numpy as np
from numpy.typing import ArrayLike

from planner.mission_path import (
    FloatArray,
    MissionPath,
    big_cone_mask,
    from_axis_frame,
    lane_end_along_m,
    path_end_m,
    straight_points,
    to_axis_frame,
)

logger = logging.getLogger(__name__)

GATE_SEARCH_M = 40.0
"""The gate's big orange cones are looked for this far (m) ahead of the car ..."""
GATE_LATERAL_M = 4.0
"""... and within this (m) beside its heading."""
RING_TOLERANCE_M = 1.0
"""A cone farther than this (m) from both rings of a circle is not one of its cones."""
MAX_CENTRE_SHIFT_M = 2.5
"""A fitted centre farther than this (m) from the guess is not believed (the guess is kept)."""


def fit_centre(points_xy_m: FloatArray, guess_xy_m: FloatArray, radii_m: tuple[float, float],
               iterations: int = 3) -> tuple[FloatArray, int]:
    """The centre (2,) (m) of concentric rings of radii ``radii_m`` (inner, outer) through
    cones ``points_xy_m`` (N, 2), each on the ring it lies nearest, from ``guess_xy_m`` (2,);
    and how many cones were used. Cones farther than :data:`RING_TOLERANCE_M` from both rings
    are left out; with fewer than 3 cones the guess is returned."""
    centre = np.asarray(guess_xy_m, np.float64).copy()
    radii = np.asarray(radii_m, np.float64)
    used = 0
    for _ in range(iterations):
        rel = points_xy_m - centre
        dist = np.hypot(rel[:, 0], rel[:, 1])
        residual = np.abs(dist[:, None] - radii[None, :])
        ring = np.argmin(residual, axis=1)
        keep = residual[np.arange(len(dist)), ring] < RING_TOLERANCE_M
        used = int(keep.sum())
        if used < 3:
            return np.asarray(guess_xy_m, np.float64).copy(), used
        p, r = points_xy_m[keep], radii[ring[keep]]
        for _ in range(5):  # Gauss-Newton on sum (|p - c| - r)^2
            rel = p - centre
            d = np.maximum(np.hypot(rel[:, 0], rel[:, 1]), 1e-9)
            jac = -rel / d[:, None]
            step, *_ = np.linalg.lstsq(jac, -(d - r), rcond=None)
            centre = centre + step
            if float(np.hypot(*step)) < 1e-4:
                break
    return centre, used


def skidpad_path(
    cones_xy_m: ArrayLike,
    colours: ArrayLike,
    sizes: ArrayLike | None,
    start_xy_m: tuple[float, float],
    start_yaw_rad: float,
    *,
    inner_diameter_m: float = 15.25,
    lane_width_m: float = 3.0,
    stop_after_centre_m: float = 15.0,
    front_m: float = 2.25,
    end_clearance_m: float = 2.0,
    extension_m: float = 1.5,
    step_m: float = 0.5,
) -> MissionPath | None:
    """The path (see the module docstring) from mapped cones ``cones_xy_m`` (N, 2) with their
    colours and sizes (N,) for a car that stood at ``start_xy_m`` heading ``start_yaw_rad``
    (rad) at the go; None when no cone is mapped ahead.

    ``timing_s_m`` are the five passes through the gate: entry, after right lap 1 and 2,
    after left lap 1 and 2 (the finish). The car stands ``stop_after_centre_m`` past the gate
    in the exit lane, nearer when a cone across the lane is mapped before that; ``front_m``,
    ``end_clearance_m``, ``extension_m`` and ``step_m`` as for
    :func:`planner.acceleration_path.acceleration_path`.
    """
    xy = np.asarray(cones_xy_m, np.float64).reshape(-1, 2)
    start = np.asarray(start_xy_m, np.float64)
    heading = float(start_yaw_rad)
    al = to_axis_frame(xy, start, heading)
    big = big_cone_mask(colours, sizes)
    gate = big & (al[:, 0] > 0.0) & (al[:, 0] < GATE_SEARCH_M) & (np.abs(al[:, 1]) < GATE_LATERAL_M)
    if int(gate.sum()) < 2:
        return _entry_only(al, start, heading, lane_width_m, front_m, end_clearance_m,
                           extension_m, step_m)
    r_in = 0.5 * inner_diameter_m
    r_out = r_in + lane_width_m
    r_mid = r_in + 0.5 * lane_width_m
    guess = xy[gate].mean(axis=0)
    normal = np.array([-math.sin(heading), math.cos(heading)])  # left of the axis
    centres = []
    for sign in (-1.0, 1.0):  # right circle, then left
        c0 = guess + sign * r_mid * normal
        side = ((xy - guess) @ normal) * sign > 0.0
        c, used = fit_centre(xy[side & ~big], c0, (r_in, r_out))
        if float(np.hypot(*(c - c0))) > MAX_CENTRE_SHIFT_M:
            logger.debug("skidpad: circle fit %.1f m from the gate's guess: guess kept",
                         float(np.hypot(*(c - c0))))
            c = c0
        centres.append(c)
    right_c, left_c = centres
    crossing = 0.5 * (right_c + left_c)
    across = left_c - right_c
    axis_heading = math.atan2(-across[0], across[1])  # the left circle lies to the left
    if math.cos(axis_heading - heading) < 0.0:  # (never for a sane fit: the gate is ahead)
        return None
    # entry: from the car's place on the axis to the crossing
    al_car = to_axis_frame(start, crossing, axis_heading)[0]
    entry = straight_points(float(al_car[0]), 0.0, step_m)[:-1]
    parts = [from_axis_frame(np.stack([entry, np.zeros_like(entry)], axis=1), crossing,
                             axis_heading)]
    # the laps: each circle from its point nearest the crossing, in the middle of its lane
    n_lap = max(int(math.ceil(2.0 * math.pi * r_mid / step_m)), 16)
    turn = np.linspace(0.0, 4.0 * math.pi, 2 * n_lap, endpoint=False)
    for centre, direction in ((right_c, -1.0), (left_c, 1.0)):
        a0 = math.atan2(*(crossing - centre)[::-1])
        ang = a0 + direction * turn
        parts.append(np.stack([centre[0] + r_mid * np.cos(ang),
                               centre[1] + r_mid * np.sin(ang)], axis=1))
    entry_m = -float(al_car[0])
    chord_m = 2.0 * r_mid * math.sin(math.pi / n_lap)  # the polyline's lap is its chords'
    timing = np.asarray(entry_m + n_lap * chord_m * np.arange(5), np.float64)
    al_cones = to_axis_frame(xy, crossing, axis_heading)
    lane_end = lane_end_along_m(al_cones, 2.0, 0.5 * lane_width_m - 0.3)
    stop = min(stop_after_centre_m, lane_end - front_m - end_clearance_m)
    stop = max(stop, 1.0)
    exit_along = straight_points(0.0, path_end_m(stop, lane_end, front_m, extension_m), step_m)
    parts.append(from_axis_frame(np.stack([exit_along, np.zeros_like(exit_along)], axis=1),
                                 crossing, axis_heading))
    points = np.vstack(parts)
    logger.debug("skidpad path: crossing %.1f m ahead, centres %.2f m apart, stop %.1f m "
                 "past it", entry_m, float(np.hypot(*across)), stop)
    return MissionPath(points, timing, float(timing[-1]) + stop)


def _entry_only(al: FloatArray, start: FloatArray, heading: float, lane_width_m: float,
                front_m: float, end_clearance_m: float, extension_m: float,
                step_m: float) -> MissionPath | None:
    """Before the gate is mapped: straight ahead to the farthest cone known near the axis,
    stopping there (or short of a cone across the lane)."""
    near = (al[:, 0] > 0.0) & (np.abs(al[:, 1]) < 2.0 * lane_width_m)
    if not near.any():
        return None
    stop = float(al[near, 0].max())
    lane_end = lane_end_along_m(al, 1.0, 0.5 * lane_width_m - 0.3)
    stop = max(min(stop, lane_end - front_m - end_clearance_m), 1.0)
    along = straight_points(0.0, path_end_m(stop, lane_end, front_m, extension_m), step_m)
    points = from_axis_frame(np.stack([along, np.zeros_like(along)], axis=1), start, heading)
    return MissionPath(points, np.zeros(0), stop, complete=False)
