"""PID, rate limiter and the throttle/brake pair: step responses, anti-windup, exclusivity."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from controller.controller import make_longitudinal
from controller.pid import PID, LongitudinalController, RateLimiter
from orchestrator.config import AppConfig


def simulate_speed(ctrl: LongitudinalController, v0: float, v_ref: float, seconds: float,
                   dt: float = 0.01) -> tuple[np.ndarray, list[tuple[float, float]]]:
    """A point mass: a = 8 throttle - 12 brake - drag, with a 50 ms actuator lag."""
    v, a = v0, 0.0
    speeds, commands = [], []
    for _ in range(int(seconds / dt)):
        throttle, brake = ctrl.update(v_ref, v, 0.0, dt)
        commands.append((throttle, brake))
        wanted = 8.0 * throttle - (12.0 * brake if v > 0 else 0.0) - 0.0015 * v * v
        a += (wanted - a) * dt / 0.05
        v = max(v + a * dt, 0.0)
        speeds.append(v)
    return np.asarray(speeds), commands


def test_speed_step_up_settles_without_big_overshoot() -> None:
    ctrl = make_longitudinal(AppConfig().controller, AppConfig().car)
    speeds, _ = simulate_speed(ctrl, 0.0, 10.0, 8.0)
    assert speeds.max() < 10.0 * 1.05  # overshoot under 5 %
    assert abs(speeds[-100:].mean() - 10.0) < 0.2  # settled
    assert np.argmax(speeds > 9.5) * 0.01 < 3.0  # within 3 s (8 m/s^2 car)


def test_speed_step_down_brakes_and_settles() -> None:
    ctrl = make_longitudinal(AppConfig().controller, AppConfig().car)
    speeds, commands = simulate_speed(ctrl, 15.0, 5.0, 6.0)
    assert speeds.min() > 5.0 * 0.9  # undershoot under 10 %
    assert abs(speeds[-100:].mean() - 5.0) < 0.2
    assert max(b for _, b in commands) > 0.2  # the brake PID did the work


def test_integrator_is_clipped() -> None:
    pid = PID(kp=0.0, ki=1.0, integral_limit=0.3, output_min=-10.0, output_max=10.0)
    for _ in range(1000):
        out = pid.update(100.0, 0.0, 0.01)
    assert pid.i == 0.3 and out == 0.3
    pid.reset()
    assert pid.integral == 0.0


def test_integrator_does_not_wind_up_in_saturation() -> None:
    pid = PID(kp=1.0, ki=1.0, integral_limit=10.0, output_min=0.0, output_max=1.0)
    for _ in range(500):
        assert pid.update(100.0, 0.0, 0.01) == 1.0
    assert pid.integral == 0.0  # saturated from the first step: nothing accumulated


def test_derivative_is_on_the_measurement() -> None:
    pid = PID(kp=0.0, kd=1.0, output_min=-100.0, output_max=100.0)
    pid.update(0.0, 0.0, 0.1)
    assert pid.update(50.0, 0.0, 0.1) == 0.0  # a setpoint step gives no derivative kick
    assert pid.update(50.0, 1.0, 0.1) == -10.0


def test_rate_limiter() -> None:
    limiter = RateLimiter(1.5)
    values = [limiter.update(1.0, 0.01) for _ in range(100)]
    assert values[0] == 0.015
    assert max(np.diff(values)) <= 0.015 + 1e-12
    assert values[-1] == 1.0


@settings(max_examples=200, deadline=None, derandomize=True)
@given(st.lists(st.tuples(st.floats(-5, 40), st.floats(0, 40), st.floats(-15, 10)),
                min_size=1, max_size=60))
def test_throttle_and_brake_never_both_above_zero(steps: list[tuple[float, float, float]]
                                                  ) -> None:
    ctrl = make_longitudinal(AppConfig().controller, AppConfig().car)
    for v_ref, v, a_ref in steps:
        throttle, brake = ctrl.update(v_ref, v, a_ref, 0.01)
        assert 0.0 <= throttle <= 1.0 and 0.0 <= brake <= 1.0
        assert not (throttle > 0.0 and brake > 0.0)
