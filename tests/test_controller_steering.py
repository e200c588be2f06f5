"""Steering laws converge onto a straight line from an offset (kinematic bicycle)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from common.messages import TargetStates
from controller.controller import make_steering_law
from controller.pid import RateLimiter
from controller.steering import PathRef
from orchestrator.config import AppConfig


def straight(length: float = 400.0) -> PathRef:
    x = np.arange(0.0, length, 0.5)
    z = np.zeros_like(x)
    return PathRef.from_targets(TargetStates(x, x, z, z, np.full_like(x, 10.0), z))


@pytest.mark.parametrize("law", ["pure_pursuit", "stanley", "heading_p"])
@pytest.mark.parametrize("speed", [5.0, 15.0])
def test_converges_onto_a_straight_line(law: str, speed: float) -> None:
    config = AppConfig()
    config.controller.steering_law = law  # type: ignore[assignment]
    car = config.car
    steer_law = make_steering_law(config.controller, car)
    limiter = RateLimiter(car.max_steer_rate_radps)
    path = straight()
    x, y, yaw, steer = 0.0, 1.5, 0.2, 0.0
    dt = 0.01
    errors = []
    for _ in range(int(15.0 / speed / dt) + 300):
        cmd = steer_law.update(x, y, yaw, speed, path)
        cmd = max(min(cmd, car.max_steer_rad), -car.max_steer_rad)
        target = limiter.update(cmd, dt)
        steer += (target - steer) * dt / car.steer_lag_s
        yaw += speed * math.tan(steer) / car.wheelbase_m * dt
        x += speed * math.cos(yaw) * dt
        y += speed * math.sin(yaw) * dt
        errors.append(y)
    errors_arr = np.abs(np.asarray(errors))
    assert errors_arr[-50:].max() < 0.05  # converged
    assert abs(yaw) < 0.02
    overshoot = max(-min(errors), 0.0)
    assert overshoot < 0.5  # crossed the line by less than half a metre


def test_path_nearest_and_at() -> None:
    path = straight(20.0)
    s, e = path.nearest(5.2, -0.4)
    assert s == pytest.approx(5.2) and e == pytest.approx(0.4)  # path to the left: positive
    x, y, yaw, k = path.at(25.0)  # beyond the end: straight on
    assert x == pytest.approx(25.0) and y == 0.0 and yaw == 0.0 and k == 0.0


def test_path_interp_is_numpys_bit_for_bit() -> None:
    from controller.steering import _interp

    rng = np.random.default_rng(5)
    xp = np.cumsum(rng.random(60) * (rng.random(60) > 0.2))  # with repeated knots
    fp = rng.standard_normal(60) * 100.0
    xs = [*rng.uniform(xp[0] - 1.0, xp[-1] + 1.0, 500).tolist(), *xp.tolist(), math.nan]
    for x in xs:
        want = float(np.interp(x, xp, fp))
        got = _interp(x, xp.tolist(), fp.tolist())
        assert got == want or (math.isnan(got) and math.isnan(want))
