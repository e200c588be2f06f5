"""The EKF SLAM's gyro calibration at the start line and the rear axle's slip read from the
accelerometer (issue 45: the explored lap's drift)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from common.car import CarConfig
from common.messages import ImuSample
from mapper.config import MapperConfig
from mapper.motion import rear_slip_from_accel, rear_slip_velocity
from mapper.slam.ekf_slam import EkfSlam

RATE_HZ = 200.0
GYRO_SIGMA_RADPS = 0.002
"""The simulated gyro's white noise per sample (config.sim.imu.gyro_sigma_radps)."""


def _stand_then_move(slam: EkfSlam, bias_radps: float, stand_s: float, seed: int) -> None:
    """Feed ``stand_s`` of a standing car's IMU (gyro = bias + white noise), then one sample of
    a launch (4 m/s^2 forward: the car moves)."""
    rng = np.random.default_rng(seed)
    n = int(stand_s * RATE_HZ)
    for k in range(n):
        gz = bias_radps + GYRO_SIGMA_RADPS * float(rng.standard_normal())
        slam.predict(ImuSample(k / RATE_HZ, 0.0, 0.0, 9.81, 0.0, 0.0, gz))
    slam.predict(ImuSample(n / RATE_HZ, 4.0, 0.0, 9.81, 0.0, 0.0, bias_radps))


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_standing_start_calibrates_the_gyro_bias_to_its_white_noise(seed: int) -> None:
    """8 s at the start line: the bias state is the gyro's mean, known to its standard error
    (0.002 / sqrt(1600) = 0.05 mrad/s), far tighter than the 5 mrad/s prior."""
    bias = 0.0031
    slam = EkfSlam(MapperConfig(), CarConfig())
    _stand_then_move(slam, bias, 8.0, seed)
    standard_error = GYRO_SIGMA_RADPS / math.sqrt(8.0 * RATE_HZ)
    est = slam.imu_bias[0]
    sigma = math.sqrt(float(slam.P[5, 5]))
    assert slam.stats["standstill_calibration"] == 1
    assert abs(est - bias) < 4.0 * standard_error
    # The filter's own uncertainty is the standard error (plus the walk over 8 s), not the prior.
    assert 0.7 * standard_error < sigma < 1.5 * standard_error


def test_calibration_off_leaves_the_prior() -> None:
    """Without it (and without landmarks to watch the yaw) the standing car tells the bias state
    nothing: it stays at its prior."""
    config = MapperConfig()
    config.slam.standstill_gyro_calibration = False
    slam = EkfSlam(config, CarConfig())
    _stand_then_move(slam, 0.0031, 8.0, 1)
    assert slam.stats["standstill_calibration"] == 0
    assert math.sqrt(float(slam.P[5, 5])) > 0.9 * config.slam.initial_gyro_bias_sigma_radps


def test_a_car_that_moves_at_once_is_not_calibrated() -> None:
    """Fewer standing samples than ``ukf.static_min_samples``: counted, the prior kept."""
    config = MapperConfig()
    slam = EkfSlam(config, CarConfig())
    _stand_then_move(slam, 0.0031, 0.1, 1)
    assert slam.stats["standstill_calibration"] == 0
    assert slam.stats["standstill_calibration_skipped"] == 1
    assert math.sqrt(float(slam.P[5, 5])) > 0.9 * config.slam.initial_gyro_bias_sigma_radps


K = 0.0073
A_MAX = 1.5 * 9.81


def test_slip_from_accel_is_the_steady_state_model_in_a_steady_corner() -> None:
    """No longitudinal force and a_y = vx w: the same slip as the steady-state model."""
    for vx, w in [(8.0, 0.5), (12.0, -0.9), (5.0, 2.0)]:
        from_accel = rear_slip_from_accel(vx, vx * w, 0.0, K, A_MAX)[0]
        steady = rear_slip_velocity(vx, w, K, A_MAX)[0]
        assert from_accel == pytest.approx(steady, rel=1e-12)


def test_slip_grows_when_the_tyres_also_drive_or_brake() -> None:
    """The friction circle: braking or driving leaves less grip for the corner, so the same
    lateral acceleration needs a larger slip angle, the same either way."""
    vx, ay = 10.0, 9.0
    free = rear_slip_from_accel(vx, ay, 0.0, K, A_MAX)[0]
    braking = rear_slip_from_accel(vx, ay, -6.0, K, A_MAX)[0]
    driving = rear_slip_from_accel(vx, ay, 6.0, K, A_MAX)[0]
    assert braking < free < 0.0          # outwards of a left turn: more negative
    assert driving == pytest.approx(braking)


@pytest.mark.parametrize("vx, ay, ax", [(9.0, 8.0, -3.0), (12.0, -5.0, 2.0), (6.0, 12.0, 9.0),
                                        (7.0, 2.0, 14.0)])
def test_slip_from_accel_derivatives_match_central_differences(vx: float, ay: float,
                                                               ax: float) -> None:
    _, d_vx, d_ay, d_ax = rear_slip_from_accel(vx, ay, ax, K, A_MAX)
    h = 1e-6

    def vy(a: float, b: float, c: float) -> float:
        return rear_slip_from_accel(a, b, c, K, A_MAX)[0]

    assert d_vx == pytest.approx((vy(vx + h, ay, ax) - vy(vx - h, ay, ax)) / (2 * h), abs=1e-7)
    assert d_ay == pytest.approx((vy(vx, ay + h, ax) - vy(vx, ay - h, ax)) / (2 * h), abs=1e-7)
    assert d_ax == pytest.approx((vy(vx, ay, ax + h) - vy(vx, ay, ax - h)) / (2 * h), abs=1e-7)
