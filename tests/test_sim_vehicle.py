"""Vehicle: braking distance, the friction limit in a steady circle, the steering actuator."""

from __future__ import annotations

import math

import pytest

from common.car import CarConfig
from common.messages import ActuatorCommand
from simulator.vehicle import Vehicle

DT = 1.0 / 200.0


def _cmd(throttle: float = 0.0, brake: float = 0.0, steer: float = 0.0) -> ActuatorCommand:
    return ActuatorCommand(0.0, throttle, brake, steer)


def test_braking_distance_from_20_mps_is_physical() -> None:
    car = CarConfig()
    v = Vehicle(car)
    v.state.vx_mps = 20.0
    steps = 0
    while v.state.vx_mps > 0.0 and steps < 2000:
        v.step(_cmd(brake=1.0), DT)
        steps += 1
    ideal = 20.0 ** 2 / (2.0 * car.max_brake_decel_mps2)  # 16.7 m
    # resistance and drag (<= 0.75 m/s^2) can only shorten it; never longer than v^2/2a
    assert ideal / (1.0 + 0.75 / 12.0) - 0.1 <= v.state.x_m <= ideal + 0.1
    assert v.state.vx_mps == 0.0
    assert abs(v.state.y_m) < 1e-9
    # standing still under brake: it stays put (no reverse)
    for _ in range(200):
        v.step(_cmd(brake=1.0), DT)
    assert v.state.vx_mps == 0.0


def test_drive_acceleration_and_top_speed() -> None:
    car = CarConfig()
    v = Vehicle(car)
    v.step(_cmd(throttle=1.0), DT)
    assert v.state.ax_mps2 == pytest.approx(car.max_drive_accel_mps2, abs=0.3)
    for _ in range(int(10.0 / DT)):
        v.step(_cmd(throttle=1.0), DT)
    assert car.top_speed_mps - 1.5 < v.state.vx_mps <= car.top_speed_mps + 1e-9


@pytest.mark.parametrize("steer_rad, speed_mps", [(0.1, 20.0), (0.2, 15.0), (0.4, 10.0),
                                                   (0.05, 10.0)])
def test_steady_circle_lateral_accel_capped_at_1_5_g(steer_rad: float, speed_mps: float) -> None:
    car = CarConfig()
    v = Vehicle(car)
    v.state.vx_mps = speed_mps
    peak = 0.0
    for k in range(int(8.0 / DT)):
        err = speed_mps - v.state.vx_mps
        throttle = min(max(0.5 * err, 0.0), 1.0)
        brake = min(max(-0.5 * err, 0.0), 1.0) if throttle == 0.0 else 0.0
        v.step(_cmd(throttle, brake, steer_rad), DT)
        if k * DT > 3.0:
            peak = max(peak, abs(v.state.ay_mps2))
    assert peak <= car.max_lateral_accel_mps2 + 0.2
    speed = v.state.speed_mps
    ay_circle = speed * abs(v.state.yaw_rate_radps)
    assert ay_circle <= car.max_lateral_accel_mps2 + 0.2
    if steer_rad == 0.05:  # well below the limit: close to the kinematic circle
        radius = car.wheelbase_m / math.tan(steer_rad)
        assert ay_circle == pytest.approx(speed * speed / radius, rel=0.25)
    else:  # at the limit: the car runs wide but still corners hard
        assert ay_circle > 0.75 * car.max_lateral_accel_mps2


def test_steering_lag_and_rate_limit() -> None:
    car = CarConfig()
    v = Vehicle(car)
    v.state.vx_mps = 5.0
    # a small step: first-order lag, ~63 % after one time constant (rate limit not reached)
    target = 0.05
    for _ in range(round(car.steer_lag_s / DT)):
        v.step(_cmd(steer=target), DT)
    assert v.state.steer_rad == pytest.approx(target * (1 - math.exp(-1.0)), abs=0.006)
    # a large step: rate-limited
    v2 = Vehicle(car)
    n = 20
    for _ in range(n):
        v2.step(_cmd(steer=0.4), DT)
    assert v2.state.steer_rad == pytest.approx(car.max_steer_rate_radps * n * DT, rel=1e-6)
    for _ in range(400):
        v2.step(_cmd(steer=1.0), DT)  # beyond the limit: clamped
    assert v2.state.steer_rad == pytest.approx(car.max_steer_rad)


def test_low_speed_is_stable_and_kinematic() -> None:
    car = CarConfig()
    v = Vehicle(car)
    for _ in range(int(20.0 / DT)):
        cmd = _cmd(throttle=0.05, steer=0.3) if v.state.vx_mps < 1.0 else _cmd(steer=0.3)
        v.step(cmd, DT)
        assert math.isfinite(v.state.x_m) and abs(v.state.ay_mps2) < 20.0
    # on a kinematic circle of radius L / tan(delta) about the rear axle
    radius = car.wheelbase_m / math.tan(0.3)
    assert v.state.vx_mps * v.state.yaw_rate_radps == pytest.approx(
        v.state.vx_mps ** 2 / radius, rel=0.05)
    assert abs(v.state.vy_mps) < 0.05


def test_outputs_footprint_wheels_truth() -> None:
    car = CarConfig()
    v = Vehicle(car)
    fp = v.footprint_xy_m()
    assert fp.shape == (4, 2)
    assert fp[:, 0].min() == pytest.approx(-car.rear_overhang_m)
    assert fp[:, 0].max() == pytest.approx(car.length_m - car.rear_overhang_m)
    assert fp[:, 1].max() - fp[:, 1].min() == pytest.approx(car.width_m)
    v.state.vx_mps = 8.0
    for _ in range(400):
        v.step(_cmd(throttle=0.1, steer=0.1), DT)
    fl, fr, rl, rr = v.wheel_speeds_mps()
    assert rr > rl > 0.0 and fr > fl  # left turn: the right wheels run faster
    assert 0.5 * (rl + rr) == pytest.approx(v.state.vx_mps, rel=0.03)
    truth = v.truth(12.5)
    assert truth.timestamp_s == 12.5 and truth.steering_rad == v.state.steer_rad
    ax, ay = v.accel_at(car.imu_x_m)
    assert ay == pytest.approx(v.state.vx_mps * v.state.yaw_rate_radps, rel=0.15)
