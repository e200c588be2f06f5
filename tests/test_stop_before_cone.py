"""With no feasible manoeuvre the car stops on a candidate (``ManoeuvreGenerator.stop_path``),
standing before the first cone that candidate would pass too near, not at its end beyond it
(planner/manoeuvres.py ``Candidate.free_m``, planner/target_states.py).

Camera dead on hard:corner-start, every seed crept on at 2 m/s along a stop path whose
clearance was -0.35 m to a cone 0.5 m ahead, braking only for the path's end 13 m on, and hit
the cone before the supervisor's no-path timeout stopped it."""

from __future__ import annotations

import math

import numpy as np
from planner_closed_loop_helpers import body_gaps_m

from common.car import CarConfig
from common.messages import TargetStates
from planner.baseframe import SplineBaseframe
from planner.config import PlannerConfig
from planner.manoeuvres import Candidate, ManoeuvreGenerator
from planner.speed_profile import SpeedLimits
from planner.target_states import timed_targets

LIMITS = SpeedLimits(lateral_mps2=8.0, drive_mps2=5.0, brake_mps2=6.0, top_speed_mps=15.0)
WALL_X_M = 9.0
"""A row of cones across the whole lane this far along +x: no manoeuvre can pass."""


def _blocked_lane() -> tuple[SplineBaseframe, np.ndarray]:
    """A straight 3 m lane along +x, closed by a row of cones across it at ``WALL_X_M``."""
    x = np.arange(-4.0, 30.0, 3.0)
    sides = np.vstack([np.stack([x, np.full_like(x, 1.5)], axis=1),
                       np.stack([x, np.full_like(x, -1.5)], axis=1)])
    y = np.arange(-6.0, 6.01, 0.3)
    wall = np.stack([np.full_like(y, WALL_X_M), y], axis=1)
    frame = SplineBaseframe(np.stack([np.linspace(-5.0, 35.0, 41), np.zeros(41)], axis=1),
                            False, step_m=0.25)
    return frame, np.vstack([sides, wall])


def _stop_targets(speed_mps: float) -> tuple[ManoeuvreGenerator, Candidate, TargetStates]:
    frame, cones = _blocked_lane()
    # the wall lies beyond the car's commitment at 3 m/s, where the far-conflict rule drives a
    # candidate standing before it (tests/test_far_conflict.py): off, to try the stop path
    generator = ManoeuvreGenerator(PlannerConfig(far_conflict_stop=False), CarConfig())
    cands, best = generator.generate(frame, 5.0, 0.0, 0.0, speed_mps, cones, None)
    assert best < 0, "the wall leaves no feasible manoeuvre"
    stop = cands[generator.stop_path(cands, speed_mps**2 / (2.0 * LIMITS.brake_mps2))]
    targets = timed_targets(stop, lambda s: np.full(len(s), 12.0), LIMITS, 0.0, stop=True,
                            min_plan_speed_mps=1.0)
    return generator, stop, targets



def test_the_stop_stands_before_the_cone_the_path_runs_into() -> None:
    speed_mps = 3.0
    generator, stop, targets = _stop_targets(speed_mps)
    _, cones = _blocked_lane()
    near_m = PlannerConfig().cone_clearance_near_m
    gaps = body_gaps_m(generator, stop.xy_m, stop.heading_rad, cones)
    assert gaps.min() < 0.0  # the candidate itself runs into a cone
    assert math.isfinite(stop.free_m)
    assert stop.free_m >= speed_mps**2 / (2.0 * LIMITS.brake_mps2)  # room to stand in time
    u = stop.s_m - stop.s_m[0]
    v = targets.speed_mps
    assert np.all(v[u >= stop.free_m] == 0.0)
    # the brakes can stand the car there from every point before it
    before = u < stop.free_m
    assert np.all(v[before] ** 2 <= 2.0 * LIMITS.brake_mps2 * (stop.free_m - u[before]) + 1e-9)
    # and wherever the car is asked to move, it is no nearer a cone than the near margin (by
    # the body: the circles may read up to their overreach nearer beside it)
    assert np.all(gaps[v > 0.0] >= near_m - generator.circle_overreach_m - 1e-9)
    assert np.any(v > 0.0)  # it is not a stop on the spot: there was room to brake


def test_a_car_already_too_near_a_cone_comes_no_nearer() -> None:
    frame, cones = _blocked_lane()
    generator = ManoeuvreGenerator(PlannerConfig(), CarConfig())
    # the car's front circle already over the wall's cone centres by 0.1 m
    axle_x = WALL_X_M + 0.1 - (float(generator.circle_offsets_m.max()) + generator.circle_radius_m)
    cands, best = generator.generate(frame, axle_x + 5.0, 0.0, 0.0, 2.0, cones, None)
    assert best < 0
    stop = cands[generator.stop_path(cands)]
    gaps = body_gaps_m(generator, stop.xy_m, stop.heading_rad, cones)
    assert gaps[0] < 0.0
    u = stop.s_m - stop.s_m[0]
    # it stands before the first point nearer than now by more than the circles' overreach,
    # which is a step or two on: the wall is straight ahead
    first = int(np.argmax(gaps < gaps[0] - generator.circle_overreach_m))
    assert first > 0 and stop.free_m == u[first - 1]
    assert stop.free_m < 2.0 * PlannerConfig().path_step_m
    targets = timed_targets(stop, lambda s: np.full(len(s), 12.0), LIMITS, 0.0, stop=True,
                            min_plan_speed_mps=1.0)
    assert np.all(targets.speed_mps[u >= stop.free_m] == 0.0)


def test_a_car_passing_through_a_gate_nearer_than_the_margin_is_not_stopped_there() -> None:
    # EPFL Vaudoise, just after the start: the car's circles 0.03 m from the start gate's
    # cones, a conflict 13-16 m on. Every stop path read a little nearer a step on (the circles
    # bulge beyond the body's side), so the stop stood at once (free_m 0), braked the car
    # fully from 4.5 m/s and changed the lap after. It brakes for the conflict ahead instead.
    frame, cones = _blocked_lane()
    generator = ManoeuvreGenerator(PlannerConfig(), CarConfig())
    # a narrow gate beside the car's front circle (s = 5: x = 0), its cones 0.03 m from it,
    # and a second 0.5 m on, 0.02 m narrower
    front_x_m = float(generator.circle_offsets_m.max())
    reach_m = generator.circle_radius_m + 0.03
    gates = np.array([[front_x_m, reach_m], [front_x_m, -reach_m],
                      [front_x_m + 0.5, reach_m - 0.02], [front_x_m + 0.5, -reach_m + 0.02]])
    every = np.vstack([cones, gates])
    speed_mps = 4.5
    cands, best = generator.generate(frame, 5.0, 0.0, 0.0, speed_mps, every, None)
    assert best < 0
    for cand in cands:  # every path passes the gate nearer than it stands now
        gaps = body_gaps_m(generator, cand.xy_m, cand.heading_rad, every)
        assert gaps[0] < PlannerConfig().cone_clearance_near_m and gaps[1:3].min() < gaps[0]
    stop = cands[generator.stop_path(cands, speed_mps**2 / (2.0 * LIMITS.brake_mps2))]
    assert stop.free_m >= speed_mps**2 / (2.0 * LIMITS.brake_mps2)
    targets = timed_targets(stop, lambda s: np.full(len(s), 12.0), LIMITS, 0.0, stop=True,
                            min_plan_speed_mps=1.0)
    assert targets.speed_mps[0] > 0.0


def test_a_path_clear_of_every_cone_has_no_stop_point() -> None:
    frame, cones = _blocked_lane()
    open_lane = cones[cones[:, 0] != WALL_X_M]
    generator = ManoeuvreGenerator(PlannerConfig(), CarConfig())
    cands, best = generator.generate(frame, 5.0, 0.0, 0.0, 3.0, open_lane, None)
    assert best >= 0 and math.isinf(cands[best].free_m)
