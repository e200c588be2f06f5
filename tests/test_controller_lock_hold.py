"""At the steering lock the car gains no speed (``controller.lock_hold_fraction``).

Where the steering law asks for more than the lock, the car cannot follow its path, and every
m/s more widens its circle through the understeer. EPFL's autocross layout (a hairpin at the
rules' 9 m outer diameter): the car sped up from 2.2 to 4.6 m/s at the lock through the hairpin,
and its front corner swept into the outer cone in every seed.

Closed loop: the Controller on the simulator's vehicle model (the pose is the truth), a plan
along a circle asking 8 m/s, sent afresh every 0.1 s."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from safety_helpers import driving_controller, health

from common.messages import Baseframe, Plan, PoseEstimate, TargetStates
from controller.safety import StopKind
from orchestrator.config import AppConfig
from simulator.vehicle import Vehicle

DT_S = 0.01
PATH_SPEED_MPS = 8.0
START_SPEED_MPS = 2.0


def _circle_plan(t_s: float, radius_m: float) -> Plan:
    """A left-hand circle through the origin heading +x (centre (0, radius)), 1.5 turns."""
    a = np.arange(0.0, 3.0 * math.pi, 0.2 / radius_m)
    x, y = radius_m * np.sin(a), radius_m * (1.0 - np.cos(a))
    n = len(a)
    targets = TargetStates(np.full(n, t_s), x, y, a, np.full(n, PATH_SPEED_MPS),
                           np.full(n, 1.0 / radius_m))
    s = radius_m * a
    z = np.zeros(n)
    return Plan(t_s, Baseframe(s, x, y, a, z, closed=False, length_m=float(s[-1])), targets,
                PATH_SPEED_MPS, chosen_index=0)


def _drive(config: AppConfig, radius_m: float, seconds: float = 3.0,
           start_speed_mps: float = START_SPEED_MPS) -> tuple[float, float, float]:
    """(highest speed, highest |steering|, farthest from the circle (m)) over ``seconds`` on
    the circle from 2 m/s, or until the supervisor stops the car."""
    ctrl = driving_controller(config)
    vehicle = Vehicle(config.car)
    vehicle.state.vx_mps = start_speed_mps
    plan = _circle_plan(0.0, radius_m)
    top_speed = top_steer = off_m = 0.0
    for k in range(int(round(seconds / DT_S))):
        t = 0.03 + k * DT_S
        if k % 10 == 0:
            plan = dataclasses.replace(_circle_plan(t, radius_m), timestamp_s=t)
        st = vehicle.state
        pose = PoseEstimate(t, st.x_m, st.y_m, st.yaw_rad, st.vx_mps, st.vy_mps,
                            st.yaw_rate_radps, np.diag([0.05**2, 0.05**2, 0.01**2]))
        cmd = ctrl.command(t, pose, plan, health(t), None)
        if ctrl.safety.stop != StopKind.NONE:
            break
        vehicle.step(cmd, DT_S)
        st = vehicle.state
        top_speed = max(top_speed, st.vx_mps)
        top_steer = max(top_steer, abs(st.steer_rad))
        off_m = max(off_m, abs(math.hypot(st.x_m, st.y_m - radius_m) - radius_m))
    return top_speed, top_steer, off_m


RADIUS_M = 2.5
"""Tighter than the lock's circle (2.67 m), as the 9 m hairpin's line can be."""


def test_a_circle_tighter_than_the_lock_is_driven_without_gaining_speed() -> None:
    """The steering sits at the lock and the car, asked for 8 m/s, stays at its 2 m/s and
    within a metre of the path: the lock's circle is 0.17 m wider, and the steering's ramp to
    the lock (0.35 s at its rate) runs the car 0.7 m along the tangent first."""
    config = AppConfig()
    lock_radius_m = config.car.wheelbase_m / math.tan(config.car.max_steer_rad)
    assert RADIUS_M < lock_radius_m
    top_speed, top_steer, off_m = _drive(config, RADIUS_M)
    assert top_steer == pytest.approx(config.car.max_steer_rad)
    assert top_speed <= START_SPEED_MPS + 0.1  # the speed loop's overshoot
    assert off_m < 1.0


def test_without_the_rule_the_car_speeds_up_at_the_lock_and_runs_wide() -> None:
    """The same circle with the rule off: the car gains speed at the lock and its circle
    widens by metres (what the rule prevents)."""
    config = AppConfig()
    config.controller.lock_hold_fraction = 0.0
    top_speed, _, off_m = _drive(config, RADIUS_M)
    assert top_speed > START_SPEED_MPS + 1.0
    assert off_m > 2.0


def test_a_car_at_a_standstill_at_the_lock_still_moves() -> None:
    """A start in a hairpin tighter than the lock: the speed held is at least
    ``lock_hold_min_speed_mps`` (the kinematic bicycle's walking pace), not the standstill."""
    config = AppConfig()
    floor_mps = config.controller.lock_hold_min_speed_mps
    top_speed, top_steer, _ = _drive(config, RADIUS_M, start_speed_mps=0.0)
    assert top_steer == pytest.approx(config.car.max_steer_rad)
    assert 0.8 * floor_mps < top_speed <= floor_mps + 0.2  # the speed loop's overshoot


def test_a_circle_within_the_lock_is_driven_up_to_its_speed() -> None:
    """Radius 12 m: well within the lock; the car speeds up toward the path's 8 m/s."""
    top_speed, top_steer, _ = _drive(AppConfig(), 12.0)
    assert top_steer < 0.9 * AppConfig().car.max_steer_rad
    assert top_speed > START_SPEED_MPS + 3.0
