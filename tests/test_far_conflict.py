"""A conflict far ahead (a cone across the lane, a bend beyond the steering's limit) beyond the
car's commitment does not throw it onto the slow fallbacks: the candidate is driven, its targets
standing before the conflict (planner/manoeuvres.py ``ManoeuvreGenerator.commit_m`` and
``_far_conflict``, planner/target_states.py).

On EPFL's Vaudoise autocross a hairpin seen 15 m ahead, its inner cone not yet mapped, bent
every candidate beyond the steering's limit there, and the car ran its fallbacks at 4 m/s for
6 s of a 15 s lap."""

from __future__ import annotations

import math

import numpy as np
import pytest
from planner_closed_loop_helpers import body_gaps_m, cone_map

from common.car import CarConfig
from planner.baseframe import SplineBaseframe
from planner.config import PlannerConfig
from planner.manoeuvres import ManoeuvreGenerator
from planner.speed_profile import SpeedLimits
from planner.target_states import timed_targets

LIMITS = SpeedLimits(lateral_mps2=8.0, drive_mps2=5.0, brake_mps2=6.0, top_speed_mps=15.0)
SPEED_MPS = 3.0


def _straight() -> SplineBaseframe:
    return SplineBaseframe(np.c_[np.linspace(0.0, 80.0, 81), np.zeros(81)], False)


def _wall(x_m: float) -> np.ndarray:
    """A row of cones across the whole lane at ``x_m``: nothing passes it."""
    return np.c_[np.full(40, x_m), np.linspace(-6.0, 6.0, 40)]



def test_a_wall_beyond_the_commitment_is_driven_towards_and_stood_before() -> None:
    generator = ManoeuvreGenerator(PlannerConfig(), CarConfig())
    commit = generator.commit_m(generator.horizon_m(SPEED_MPS), SPEED_MPS)
    wall = _wall(14.0)
    cands, best = generator.generate(_straight(), 0.0, 0.0, 0.0, SPEED_MPS, wall, None)
    assert best >= 0
    chosen = cands[best]
    assert generator.rejections["wide: far conflict taken"] == 1
    assert not chosen.collision_free and chosen.hit_m > commit
    assert math.isfinite(chosen.stand_before_m) and chosen.stand_before_m < chosen.hit_m
    targets = timed_targets(chosen, lambda s: np.full(len(s), 12.0), LIMITS, 0.0, stop=False,
                            min_plan_speed_mps=1.0)
    assert targets.speed_mps[0] > SPEED_MPS  # it drives on: the wall is far
    moving = targets.speed_mps > 0.0
    # wherever a target still moves, the body keeps the hard margin to the wall
    gaps = body_gaps_m(generator, chosen.xy_m[moving], chosen.heading_rad[moving], wall)
    assert gaps.min() >= generator.config.cone_clearance_m - 1e-9
    # and it can stand there within the brakes
    ds = np.linalg.norm(np.diff(chosen.xy_m, axis=0), axis=1)
    v = targets.speed_mps
    assert np.all(v[:-1] ** 2 - v[1:] ** 2 <= 2.0 * LIMITS.brake_mps2 * ds + 1e-9)


def test_a_wall_within_the_commitment_still_refuses_every_family() -> None:
    generator = ManoeuvreGenerator(PlannerConfig(), CarConfig())
    _, best = generator.generate(_straight(), 0.0, 0.0, 0.0, SPEED_MPS, _wall(5.0), None)
    assert best == -1
    assert generator.rejections["wide: far conflict taken"] == 0


def test_switched_off_a_far_wall_refuses_every_family() -> None:
    generator = ManoeuvreGenerator(PlannerConfig(far_conflict_stop=False), CarConfig())
    _, best = generator.generate(_straight(), 0.0, 0.0, 0.0, SPEED_MPS, _wall(14.0), None)
    assert best == -1


@pytest.mark.parametrize(("bend_at_m", "far"), [(16.0, True), (3.0, False)])
def test_a_bend_beyond_the_steering_limit_far_ahead_is_stood_before(bend_at_m: float,
                                                                    far: bool) -> None:
    """A straight that turns back through a 1 m radius, the offsets within 1 m of it (the car
    turns no tighter than about 2.8 m: every candidate bends beyond that): far ahead the car
    drives on and stands before it; within its commitment the far rule does not apply."""
    radius = 1.0
    a = np.linspace(0.0, math.pi, 40)
    bend = np.c_[bend_at_m + radius * np.sin(a), radius - radius * np.cos(a)]
    line = np.r_[np.c_[np.linspace(0.0, bend_at_m, 60), np.zeros(60)][:-1], bend,
                 np.c_[np.linspace(bend_at_m, bend_at_m - 20.0, 40), np.full(40, 2 * radius)][1:]]
    frame = SplineBaseframe(line, False, resample_m=0.5, smoothing_m=0.0, step_m=0.25)
    generator = ManoeuvreGenerator(PlannerConfig(offsets_max_m=1.0, offsets_wide_max_m=1.0),
                                   CarConfig())
    cands, best = generator.generate(frame, 0.0, 0.0, 0.0, SPEED_MPS, np.zeros((0, 2)), None)
    taken = generator.rejections["wide: far conflict taken"] == 1
    assert taken == far
    if far:
        chosen = cands[best]
        assert chosen.bent_m > generator.commit_m(generator.horizon_m(SPEED_MPS), SPEED_MPS)
        targets = timed_targets(chosen, lambda s: np.full(len(s), 12.0), LIMITS, 0.0,
                                stop=False, min_plan_speed_mps=1.0)
        beyond = (chosen.s_m - chosen.s_m[0]) >= chosen.bent_m
        assert np.all(targets.speed_mps[beyond] == 0.0)


@pytest.mark.parametrize("coloured", [True, False])
def test_the_planner_allows_a_far_conflict_only_with_colours(
        coloured: bool, monkeypatch: pytest.MonkeyPatch) -> None:
    """Without colours (the camera dead) the lane ahead is a guess from the cones' shape: a
    conflict there is the sign that the guess is wrong, so the car keeps to the fallbacks
    (with it, camera-dead `hard:hairpins` drove on at 6-10 m/s and left the track)."""
    from common.messages import MapState, PoseEstimate
    from orchestrator.config import AppConfig
    from planner.path_planner import PathPlanner
    from simulator.tracks import load_track

    seen: list[bool] = []
    generate = ManoeuvreGenerator.generate

    def spy(self: ManoeuvreGenerator, *args: object, **kwargs: object) -> object:
        seen.append(bool(kwargs.get("far_conflicts", True)))
        return generate(self, *args, **kwargs)  # type: ignore[arg-type]

    monkeypatch.setattr(ManoeuvreGenerator, "generate", spy)
    config = AppConfig()
    track = load_track("gen:2")
    colours = track.colours if coloured else np.zeros_like(track.colours)
    cones = cone_map(track.cones_xy_m, colours)
    c = track.centreline_xy_m
    pose = PoseEstimate(0.0, float(c[0, 0]), float(c[0, 1]),
                        math.atan2(c[1, 1] - c[0, 1], c[1, 0] - c[0, 0]), 0.0, 0.0, 0.0,
                        np.eye(3) * 1e-4)
    planner = PathPlanner(config.planner, config.car)
    planner.start_autonomous(MapState(0.0, pose, cones, loop_closed=False))
    planner.plan(MapState(0.1, pose, cones, loop_closed=False), 0.1)
    assert seen == [coloured]


def test_colours_count_only_ahead_of_the_car() -> None:
    """The camera died a while ago: the map keeps the colours of the cones it saw behind the
    car, and those ahead, seen by the LiDAR alone, have none. Far conflicts are then off."""
    from common.messages import ConeColour
    from planner.gate_search import coloured_ahead

    x = np.arange(-30.0, 30.0, 5.0)
    xy = np.r_[np.c_[x, np.full(len(x), 1.5)], np.c_[x, np.full(len(x), -1.5)]]
    seen_before = np.r_[x, x] < 0.0
    colours = np.where(seen_before, int(ConeColour.BLUE), int(ConeColour.UNKNOWN))
    assert not coloured_ahead(xy, colours, (0.0, 0.0), 0.0, 20.0)
    # turned round, the coloured cones are the ones ahead
    assert coloured_ahead(xy, colours, (0.0, 0.0), math.pi, 20.0)
    # nothing ahead within reach: no colours to trust either
    assert not coloured_ahead(xy, colours, (100.0, 0.0), 0.0, 20.0)
