"""A chosen manoeuvre as timed target states (planner/target_states.py)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from planner.manoeuvres import Candidate
from planner.speed_profile import SpeedLimits
from planner.target_states import empty_targets, timed_targets

LIMITS = SpeedLimits(lateral_mps2=8.0, drive_mps2=5.0, brake_mps2=6.0, top_speed_mps=15.0)


def _straight(length_m: float = 20.0, step_m: float = 0.5, kappa: float = 0.0) -> Candidate:
    s = np.arange(0.0, length_m + 1e-9, step_m)
    xy = np.stack([s, np.zeros_like(s)], axis=1)
    z = np.zeros_like(s)
    return Candidate(0.0, s, z, xy, z, np.full_like(s, kappa), math.inf, True, 0.0)


def test_a_stop_brakes_within_the_limits_to_stand_at_the_end() -> None:
    cand = _straight()
    targets = timed_targets(cand, lambda s: np.full(len(s), 10.0), LIMITS, 5.0, stop=True,
                            min_plan_speed_mps=1.0)
    v = targets.speed_mps
    assert v[-1] == 0.0 and v[0] == 10.0
    # no point asks more than the brakes can do over the distance to the next
    ds = np.diff(cand.s_m)
    assert np.all(v[:-1] ** 2 <= v[1:] ** 2 + 2.0 * LIMITS.brake_mps2 * ds + 1e-9)
    assert targets.t_s[0] == 5.0 and np.all(np.diff(targets.t_s) > 0.0)


def test_the_speed_is_the_least_of_profile_friction_and_cap_and_never_below_the_floor() -> None:
    bend = _straight(kappa=0.2)  # sqrt(8 / 0.2) = 6.3 m/s on the friction circle
    targets = timed_targets(bend, lambda s: np.full(len(s), 12.0), LIMITS, 0.0, stop=False,
                            min_plan_speed_mps=1.0)
    assert np.allclose(targets.speed_mps, math.sqrt(8.0 / 0.2))
    slow = timed_targets(_straight(), lambda s: np.full(len(s), 0.2), LIMITS, 0.0, stop=False,
                         min_plan_speed_mps=1.0)
    assert np.allclose(slow.speed_mps, 0.2)  # the floor never lifts a slower limit
    crawl = dataclasses.replace(_straight(), speed_cap_mps=3.0)
    capped = timed_targets(crawl, lambda s: np.full(len(s), 12.0), LIMITS, 0.0, stop=False,
                           min_plan_speed_mps=1.0)
    assert np.allclose(capped.speed_mps, 3.0)
    # 20 m at 3 m/s
    assert math.isclose(capped.t_s[-1], 20.0 / 3.0, rel_tol=1e-9)
    assert len(empty_targets().t_s) == 0
