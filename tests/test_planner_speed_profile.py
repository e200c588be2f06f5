"""Speed profile: friction circle, forward-backward pass, two-level mode, minimum lap time."""

from __future__ import annotations

import math

import numpy as np
import pytest

from common.car import CarConfig
from planner.speed_profile import (
    SpeedLimits,
    forward_backward_speed_mps,
    lap_time_s,
    min_lap_time_s,
    steering_angle_speed_limit_mps,
    two_level_speed_mps,
)

LIMITS = SpeedLimits(lateral_mps2=12.0, drive_mps2=6.0, brake_mps2=10.0, top_speed_mps=25.0)


@pytest.mark.parametrize("r", [8.0, 20.0, 100.0])
def test_circle_speed_is_sqrt_a_lat_r(r: float) -> None:
    kappa = np.full(200, 1.0 / r)
    ds = np.full(200, 2 * math.pi * r / 200)
    v = forward_backward_speed_mps(kappa, ds, LIMITS, closed=True)
    np.testing.assert_allclose(v, min(math.sqrt(LIMITS.lateral_mps2 * r), 25.0), rtol=1e-9)


def test_safety_factor_scales_the_circle_speed() -> None:
    car = CarConfig()
    limits = SpeedLimits.from_car(car, 0.85)
    v = forward_backward_speed_mps(np.full(50, 0.1), np.full(50, 1.0), limits, closed=True)
    assert v[0] == pytest.approx(math.sqrt(0.85 * car.max_lateral_accel_mps2 / 0.1))


def test_profile_respects_drive_and_brake_limits() -> None:
    # a straight between two tight corners, closed
    kappa = np.r_[np.full(20, 0.2), np.zeros(300), np.full(20, -0.2), np.zeros(100)]
    ds = np.full(len(kappa), 0.5)
    v = forward_backward_speed_mps(kappa, ds, LIMITS, closed=True)
    assert np.all(v * v * np.abs(kappa) <= LIMITS.lateral_mps2 + 1e-6)
    assert np.all(v <= LIMITS.top_speed_mps + 1e-9)
    a = (np.roll(v, -1) ** 2 - v**2) / (2 * ds)
    assert a.max() <= LIMITS.drive_mps2 + 1e-6
    assert a.min() >= -LIMITS.brake_mps2 - 1e-6
    assert v.max() == pytest.approx(25.0)  # the straight is long enough to reach top speed


def test_open_profile_starts_and_ends_as_asked() -> None:
    v = forward_backward_speed_mps(np.zeros(101), np.full(100, 1.0), LIMITS, closed=False,
                                   v_start_mps=0.0, v_end_mps=0.0)
    assert v[0] == 0.0 and v[-1] == 0.0
    assert v[1] == pytest.approx(math.sqrt(2 * LIMITS.drive_mps2 * 1.0))
    assert v[-2] == pytest.approx(math.sqrt(2 * LIMITS.brake_mps2 * 1.0))


def test_two_level_is_slow_before_turns() -> None:
    s = np.arange(0.0, 100.0, 0.5)
    heading = np.where(s < 50.0, 0.0, np.minimum((s - 50.0) * 0.1, 1.5))
    v = two_level_speed_mps(s, heading, False, 100.0, 8.0, 4.0, 0.35, 10.0)
    assert set(np.unique(v)) == {4.0, 8.0}
    assert v[0] == 8.0 and v[int(45 / 0.5)] == 4.0


def test_min_lap_time_on_a_circle() -> None:
    car = CarConfig()
    r = 15.0
    t = np.linspace(0, 2 * np.pi, 150, endpoint=False)
    lap = min_lap_time_s(np.stack([r * np.cos(t), r * np.sin(t)], axis=1), car)
    expected = 2 * math.pi * r / math.sqrt(car.max_lateral_accel_mps2 * r)
    assert lap == pytest.approx(expected, rel=0.01)


def test_lap_time_of_constant_speed() -> None:
    assert lap_time_s(np.full(10, 5.0), np.full(10, 1.0)) == pytest.approx(2.0)



def test_the_steering_lock_limits_the_speed_on_a_tight_bend() -> None:
    """The steering needed is atan(L kappa) + K v^2 kappa: at the limit speed it is the lock;
    a bend tighter than the lock holds at any speed gets the floor, a straight no limit."""
    wheelbase, lock, k_us = 1.53, 0.5, 0.004
    kappa = np.array([0.0, 0.1, 0.2, 0.3, 0.5])
    v = steering_angle_speed_limit_mps(kappa, wheelbase, lock, k_us, floor_mps=2.0)
    assert v[0] > 100.0
    for i in (1, 2, 3):
        steer = math.atan(wheelbase * kappa[i]) + k_us * v[i] ** 2 * kappa[i]
        assert steer == pytest.approx(lock, rel=1e-9)
    assert v[1] > v[2] > v[3] > 2.0
    assert math.atan(wheelbase * 0.5) > lock and v[4] == 2.0
