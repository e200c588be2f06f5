"""EKF SLAM through a silent IMU: when another sensor's reading comes after the IMU has been
silent longer than ``max_predict_dt_s`` (a stalled serial link, a stalled computer: issue 19's
loaded CI run lost 1.4 s of IMU during the exploration lap and the map broke), the filter moves
on with the last sample's input held. That input is a guess, and the covariance must say so,
or the cones after the gap no longer fit their landmarks and the map is drawn twice."""

from __future__ import annotations

import math

import numpy as np

from common.car import CarConfig
from common.messages import ImuSample, WheelSpeeds
from mapper.config import MapperConfig
from mapper.slam.ekf_slam import EkfSlam
from mapper.slam.models import POSE_DIM

SPEED_MPS = 7.0
YAW_RATE_RADPS = 0.5
GAP_S = 1.4


def _curve_then_silence(held_gyro_sigma_radps: float) -> tuple[EkfSlam, float]:
    """1 s of a steady 0.5 rad/s curve at 7 m/s from the IMU (200 Hz), then the IMU silent
    for 1.4 s while the car drives straight on (the truth's yaw stays where the curve left
    it), then one wheel reading. Returns the filter and its yaw error (rad)."""
    config = MapperConfig()
    config.slam.held_gyro_sigma_radps = held_gyro_sigma_radps
    slam = EkfSlam(config, CarConfig(imu_x_m=0.0))
    x = np.zeros(slam.x.size)
    x[3] = SPEED_MPS
    slam.load_state(x, np.eye(slam.x.size) * 1e-6)
    for k in range(201):
        slam.predict(ImuSample(k * 0.005, 0.0, SPEED_MPS * YAW_RATE_RADPS, 9.81,
                               0.0, 0.0, YAW_RATE_RADPS))
    true_yaw = YAW_RATE_RADPS * 1.0
    v = SPEED_MPS
    slam.update_odometry(WheelSpeeds(1.0 + GAP_S, v, v, v, v))
    error = math.remainder(float(slam.x[2]) - true_yaw, math.tau)
    return slam, error


def test_a_held_input_widens_the_yaw_to_cover_what_the_car_may_have_done() -> None:
    """The held 0.5 rad/s turns the filter 0.7 rad past the straightened car; the widened
    yaw sigma (0.5 rad/s x 1.4 s) covers that within 3 sigma, and the widening is counted
    once. Without it the error is hundreds of the filter's own sigmas."""
    slam, error = _curve_then_silence(0.5)
    sigma = math.sqrt(float(slam.P[2, 2]))
    assert abs(error) > 0.6  # the held input did turn the filter on
    assert abs(error) <= 3.0 * sigma
    assert slam.stats["held_input_widened"] == 1
    # position: the yaw error moves the car sideways by about v * error * gap / 2
    sideways_m = SPEED_MPS * abs(error) * GAP_S / 2.0
    position_sigma = math.sqrt(float(max(slam.P[0, 0], slam.P[1, 1])))
    assert sideways_m <= 3.0 * position_sigma
    assert np.all(np.linalg.eigvalsh(slam.P[:POSE_DIM, :POSE_DIM]) > 0.0)

    overconfident, error = _curve_then_silence(0.0)
    assert abs(error) > 30.0 * math.sqrt(float(overconfident.P[2, 2]))


def test_readings_between_imu_samples_widen_nothing() -> None:
    """A wheel reading 5 ms after the last IMU sample is the normal interleaving: no widening
    (the covariance is the one a filter that never widens gets, bit for bit)."""
    filters = []
    for held_sigma in (0.5, 0.0):
        config = MapperConfig()
        config.slam.held_gyro_sigma_radps = held_sigma
        config.slam.held_accel_sigma_mps2 = held_sigma * 10.0
        slam = EkfSlam(config, CarConfig(imu_x_m=0.0))
        for k in range(21):
            slam.predict(ImuSample(k * 0.005, 0.0, 0.0, 9.81, 0.0, 0.0, 0.0))
        slam.update_odometry(WheelSpeeds(0.105, 0.0, 0.0, 0.0, 0.0))
        filters.append(slam)
    assert "held_input_widened" not in filters[0].stats
    assert np.array_equal(filters[0].P, filters[1].P)
