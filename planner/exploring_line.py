"""A line the car can steer through a bend seen for the first time (issue 45).

The path through the gates seen (:mod:`planner.exploration_path`) runs through the middles of
the gates as the cone pairs come: in a tight bend those pairs are not across the track, their
middles lie inside the bend's middle, and the path through them bends tighter than the bend.
On a rules-minimum hairpin (9 m outer diameter, 3 m wide: 0.33 1/m on its middle) it bent at
0.43-0.53 1/m, beyond the car's steering lock (0.36 1/m at the manoeuvres' 95 %): every
manoeuvre along it was then too sharp, the least sharp was driven at the lock, the car fell
behind it and rounded the hairpin about 3 m from its centre, where the front corner swings out
over the outer cones (``hard:hairpins``: cones hit in 5 of 8 seeds).

Where the frame bends beyond that limit ahead of the car, the car drives instead the line on
which its body has the most room between the boundaries the cones seen give (each side's cones
joined in order, :func:`planner.track_model.side_boundaries`): first the middle between them,
then, about that middle, the offset at which the lesser room on either side of the body is
largest (on the outside of a bend the front corner swings out:
:func:`planner.racing_line.body_margins_m`). In a rules-minimum hairpin that puts the rear
axle about 2.5 m from the bend's centre instead of the gates' 2.85 m, and the body 0.29-0.32 m
from the cones' centres instead of 0.19-0.23 m. The line is taken only when its sharpest bend
is gentler than the gates' path's (on the way into that hairpin, at about half the plans);
elsewhere the path through the gates stays as it is.

Measured (autocross): ``hard:hairpins`` seeds 1-24, 21 clean (10 without); EUFS
``Hairpin_02_03_2023`` explored 1.60-1.63x the friction limit -> 1.33-1.38x; EUFS
``SmallCircle`` (a 3 m circle: a lap-long hairpin, where the line is tighter than the lock
and the car crawls) 2.02-2.24x -> 2.19-2.40x.
"""

from __future__ import annotations

import logging

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


def bends_beyond(frame: SplineBaseframe, from_s_m: float, limit_1pm: float) -> bool:
    """Whether ``frame`` bends tighter than ``limit_1pm`` (1/m) anywhere from ``from_s_m`` (m)
    on (before it, the frame bends from the car to the middle of the track: the manoeuvre's
    own curvature is checked there)."""
    ahead = frame.curvature_1pm[frame.s_m >= from_s_m]
    return bool(len(ahead) and np.max(np.abs(ahead)) > limit_1pm)


def steerable_frame(frame: SplineBaseframe, cones_xy_m: FloatArray, colours: NDArray[np.int64],
                    car_xy_m: tuple[float, float], car: CarConfig, config: PlannerConfig,
                    limit_1pm: float) -> SplineBaseframe | None:
    """The frame along the line with the most room for the car's body (module docstring)
    through the stretch of track of the open ``frame``, when ``frame`` bends tighter than
    ``limit_1pm`` (1/m; the manoeuvres' limit) beyond ``exploration_start_m`` ahead of the car
    at ``car_xy_m`` (m), and the line's sharpest bend is gentler than ``frame``'s there; else
    None (keep ``frame``).

    ``cones_xy_m`` (N, 2) and ``colours`` (N,) (:class:`common.messages.ConeColour`): the cones
    seen (world frame); a cone of unknown colour bounds the side it lies on."""
    if frame.closed:
        return None
    from_s_m = frame.project(*car_xy_m)[0] + config.exploration_start_m
    if not bends_beyond(frame, from_s_m, limit_1pm):
        return None
    c = config
    every = max(int(round(LINE_STEP_M / frame.step_m)), 1)
    if len(frame.s_m[::every]) < 4:
        return None
    try:
        left_xy, right_xy = side_boundaries(frame, cones_xy_m, colours,
                                            c.nominal_track_width_m, c.nominal_track_width_m)
        # the middle between the boundaries first (a tight bend's gates have their middles
        # inside it), then where the body has the most room about it (its front swings out)
        middle_xy = _most_room(frame.xy_m[::every], frame.heading_rad[::every], left_xy,
                               right_xy, np.zeros(1), np.zeros(1))
        middle = SplineBaseframe(middle_xy, False, resample_m=c.baseframe_resample_m,
                                 smoothing_m=c.racing_line_smoothing_m, step_m=LINE_STEP_M)
        left, right = body_margins_m(menger_curvature(middle.xy_m, False), car.width_m / 2.0,
                                     car.length_m - car.rear_overhang_m, 0.0)
        line_xy = _most_room(middle.xy_m, middle.heading_rad, left_xy, right_xy, left, right)
        steered = SplineBaseframe(line_xy, False, resample_m=c.baseframe_resample_m,
                                  smoothing_m=c.racing_line_smoothing_m,
                                  step_m=c.baseframe_step_m)
    except (TrackError, ValueError) as exc:
        logger.debug("steerable frame: none (%s)", exc)
        return None
    before = float(np.max(np.abs(frame.curvature_1pm[frame.s_m >= from_s_m])))
    after = float(np.max(np.abs(steered.curvature_1pm)))
    if not after < before:
        return None
    logger.debug("steerable frame: max |kappa| %.3f -> %.3f 1/m", before, after)
    return steered


def _most_room(centre_xy_m: FloatArray, heading_rad: FloatArray, left_xy_m: FloatArray,
               right_xy_m: FloatArray, left_margin_m: FloatArray, right_margin_m: FloatArray
               ) -> FloatArray:
    """``centre_xy_m`` (N, 2) moved along its normals (from ``heading_rad`` (N,)) to
    :func:`planner.track_model.most_room_offsets` within :data:`REACH_M`."""
    normals = np.stack([-np.sin(heading_rad), np.cos(heading_rad)], axis=1)
    n = len(centre_xy_m)
    offsets = most_room_offsets(centre_xy_m, normals, left_xy_m, right_xy_m,
                                np.broadcast_to(left_margin_m, n),
                                np.broadcast_to(right_margin_m, n), REACH_M)
    return np.asarray(centre_xy_m + offsets[:, None] * normals, np.float64)
