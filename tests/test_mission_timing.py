"""The events' timing on the ground truth: the car's front on the lines, skidpad laps told right
or left, the second of each side timed."""

from __future__ import annotations

import math

import numpy as np
import pytest

from common.messages import GroundTruth
from simulator.mission_timing import MissionTimer

FRONT_M = 2.25


def _truth(t_s: float, x_m: float, y_m: float, yaw_rad: float) -> GroundTruth:
    return GroundTruth(t_s, x_m, y_m, yaw_rad, 0.0, 0.0, 0.0)


def test_skidpad_laps_right_then_left_at_constant_speed() -> None:
    """A figure of eight driven at 10 m/s: entry along +x to the gate at x = 15, two laps of
    the right circle (centre (15, -9)), two of the left, exit: each lap 2 pi 9 / 10 s."""
    gate = np.array([[15.0, -1.5], [15.0, 1.5]])
    timer = MissionTimer("skidpad", gate, gate, FRONT_M)
    speed, radius, dt = 10.0, 9.0, 0.01
    t = 0.0
    # the origin runs FRONT_M behind the front: the front reaches the gate first
    for x in np.arange(0.0, 15.0, speed * dt):
        timer.observe(_truth(t, float(x), 0.0, 0.0))
        t += dt
    omega = speed / radius
    for centre_y, sign in ((-radius, -1.0), (radius, 1.0)):
        a0 = math.pi / 2 if sign < 0 else -math.pi / 2
        for k in range(int(round(2 * 2 * math.pi / (omega * dt)))):
            a = a0 + sign * omega * dt * k
            x, y = 15.0 + radius * math.cos(a), centre_y + radius * math.sin(a)
            timer.observe(_truth(t, x, y, a + sign * math.pi / 2))
            t += dt
    for x in np.arange(15.0, 30.0, speed * dt):
        timer.observe(_truth(t, float(x), 0.0, 0.0))
        t += dt
    result = timer.result()
    lap_s = 2 * math.pi * radius / speed
    assert [lap["side"] for lap in result["laps"]] == ["right", "right", "left", "left"]
    assert result["right_timed_lap_s"] == pytest.approx(lap_s, abs=0.05)
    assert result["left_timed_lap_s"] == pytest.approx(lap_s, abs=0.05)
    assert result["mean_timed_lap_s"] == pytest.approx(lap_s, abs=0.05)


def test_acceleration_is_timed_front_to_front() -> None:
    """Constant 8 m/s^2 from standstill with the front 0.5 m behind the start line: the front
    covers 75 m between the lines from 2.83 m/s."""
    start = np.array([[2.75, -1.5], [2.75, 1.5]])
    finish = np.array([[77.75, -1.5], [77.75, 1.5]])
    timer = MissionTimer("acceleration", start, finish, FRONT_M)
    accel, dt = 8.0, 0.001
    for k in range(6000):
        t = k * dt
        timer.observe(_truth(t, 0.5 * accel * t * t, 0.0, 0.0))
    t0 = math.sqrt(2 * 0.5 / accel)
    t1 = math.sqrt(2 * 75.5 / accel)
    result = timer.result()
    assert result["time_s"] == pytest.approx(t1 - t0, abs=2e-3)
