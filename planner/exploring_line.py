"""A line the car can steer through a bend seen for the first time (issue 45).

The path through the gates seen (:mod:`planner.exploration_path`) runs through the middles of
the gates as the cone pairs come: in a tight bend those pairs are not across the track, their
middles lie inside the bend's middle, and the path through them bends tighter than the bend.
On a rules-minimum hairpin (9 m outer diameter, 3 m wide: 0.33 1/m on its middle) it bent at
0.43-0.53 1/m, beyond the car's steering lock (0.36 1/m at the manoeuvres' 95 %): every
manoeuvre along it was then too sharp, the least sharp was driven at the lock, the car fell
behind it, and it left the hairpin at the lock, pointing 45 degrees wide, into the outer
cones (``hard:hairpins``: cones hit in 5 of 8 seeds).

Where the frame bends beyond that limit, it is replaced by the least curved line between the
boundaries the cones seen give (:func:`planner.track_model.track_from_cones` along the frame,
:func:`planner.racing_line.min_curvature_offsets` within them, the car's body and a margin
kept from the cones, as the mapped laps' racing line). Only then: elsewhere the path through
the gates stays as it is, so this costs nothing on the open bends where it is not needed.
"""

from __future__ import annotations

import logging
import math

import numpy as np
from numpy.typing import NDArray

from common.car import CarConfig
from common.errors import TrackError
from planner.baseframe import SplineBaseframe
from planner.config import PlannerConfig
from planner.racing_line import body_margins_m
from planner.track_model import menger_curvature, most_room_offsets, side_boundaries

logger = logging.getLogger(__name__)

FloatArray = NDArray[np.float64]

LINE_STEP_M = 0.5
"""Spacing (m) of the line's samples."""
REACH_M = 2.0
"""How far (m) either side of the gates' path the line may move."""
BEHIND_M = 10.0
"""The line starts this far (m) behind the car."""


def lock_curvature_1pm(car: CarConfig, config: PlannerConfig) -> float:
    """The tightest curvature (1/m) a manoeuvre may have: ``curvature_limit_fraction`` of the
    steering lock's, tan(max steer) / wheelbase."""
    return math.tan(car.max_steer_rad) / car.wheelbase_m * config.curvature_limit_fraction


def bends_beyond_lock(frame: SplineBaseframe, from_s_m: float, limit_1pm: float) -> bool:
    """Whether ``frame`` bends tighter than ``limit_1pm`` (1/m) anywhere from ``from_s_m`` (m)
    on (before it, the frame bends from the car to the middle of the track: the manoeuvre's
    own curvature is checked there)."""
    ahead = frame.curvature_1pm[frame.s_m >= from_s_m]
    return bool(len(ahead) and np.max(np.abs(ahead)) > limit_1pm)


def steerable_frame(frame: SplineBaseframe, cones_xy_m: FloatArray, colours: NDArray[np.int64],
                    car: CarConfig, config: PlannerConfig, from_s_m: float = 0.0
                    ) -> SplineBaseframe | None:
    """A frame through the same stretch of track as the open ``frame`` that bends no tighter
    than the car can steer where the cones allow, or None when ``frame`` needs none (it
    bends within :func:`lock_curvature_1pm` from ``from_s_m`` on) or no better one is found.

    ``cones_xy_m`` (N, 2) and ``colours`` (N,): the cones seen (world frame). The line keeps
    the car's body (its half width; on the outside of a bend, what the front corner swings out)
    plus ``cone_radius_m`` and ``racing_margin_m`` from the boundaries joined through them."""
    limit = lock_curvature_1pm(car, config)
    if frame.closed or not bends_beyond_lock(frame, from_s_m, limit):
        return None
    c = config
    ahead = frame.s_m >= from_s_m - BEHIND_M
    every = max(int(round(LINE_STEP_M / frame.step_m)), 1)
    centre = frame.xy_m[ahead][::every]
    heading = frame.heading_rad[ahead][::every]
    if len(centre) < 4:
        return None
    try:
        left_xy, right_xy = side_boundaries(frame, cones_xy_m, colours,
                                            c.nominal_track_width_m, c.nominal_track_width_m)
    except TrackError as exc:
        logger.debug("steerable frame: no boundaries (%s)", exc)
        return None
    # the middle between the boundaries first (the gates' middles lie inside a tight bend's),
    # then where the car's body has the most room about it (its front swings out in a bend)
    for body in (False, True):
        normals = np.stack([-np.sin(heading), np.cos(heading)], axis=1)
        kappa = menger_curvature(centre, False)
        left, right = body_margins_m(kappa, car.width_m / 2.0, car.length_m - car.rear_overhang_m,
                                     0.0) if body else (np.zeros(len(centre)),) * 2
        line = centre + most_room_offsets(centre, normals, left_xy, right_xy, left, right,
                                          REACH_M)[:, None] * normals
        if not body:
            try:
                middle = SplineBaseframe(line, False, resample_m=c.baseframe_resample_m,
                                         smoothing_m=c.racing_line_smoothing_m,
                                         step_m=LINE_STEP_M)
            except (TrackError, ValueError):
                return None
            centre, heading = middle.xy_m, middle.heading_rad
    try:
        steered = SplineBaseframe(line, False, resample_m=c.baseframe_resample_m,
                                  smoothing_m=c.racing_line_smoothing_m,
                                  step_m=c.baseframe_step_m)
    except (TrackError, ValueError) as exc:
        logger.debug("steerable frame: no spline through the line (%s)", exc)
        return None
    before = float(np.max(np.abs(frame.curvature_1pm[frame.s_m >= from_s_m])))
    after = float(np.max(np.abs(steered.curvature_1pm)))
    if not after < before:
        return None
    logger.debug("steerable frame: max |kappa| %.3f -> %.3f 1/m", before, after)
    return steered
