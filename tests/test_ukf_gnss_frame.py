"""The GNSS world frame's heading: its estimate and sigma, the UKF's heading offset state, and
the yaw integration that the heading consistency rests on."""

from __future__ import annotations

import math

import numpy as np
import pytest

from common.conventions import LocalTangentFrame
from common.messages import ImuSample
from mapper.gnss_frame import GnssFrameEstimator
from mapper.motion import predict_forward
from mapper.ukf_localiser import UkfLocaliser
from orchestrator.config import AppConfig

COURSE_SIGMA_RAD = 0.05
"""The simulated receiver's course noise (config.sim.gps.course_sigma_rad)."""


def _frame_heading_z(seed: int) -> tuple[float, float, float, float]:
    """One drive: courses with 0.05 rad noise against a filter whose yaw has a slow error
    (2 mrad, correlated over 5 s). Returns the normalised errors of the frame heading from the
    first 100 samples and from all 600, and their sigmas (rad)."""
    rng = np.random.default_rng(seed)
    true_heading = 0.4
    est = GnssFrameEstimator(LocalTangentFrame(47.0, 8.0, 400.0), None, heading_samples=100,
                             min_speed_mps=1.0, alignment_distance_m=20.0,
                             max_yaw_rate_radps=1.0, yaw_error_correlation_s=5.0)
    yaw_sigma = 0.002
    slow_error = 0.0
    z_first = sigma_first = math.nan
    for k in range(600):
        t = 0.1 * k
        slow_error = 0.98 * slow_error + math.sqrt(1 - 0.98**2) * rng.normal(0.0, yaw_sigma)
        yaw_true = 0.01 * t
        state = np.array([10.0 * t, 0.0, yaw_true + slow_error, 10.0, 0.0])
        course = true_heading + yaw_true + rng.normal(0.0, COURSE_SIGMA_RAD)
        frame = est.add(100.0 * k, 0.0, 10.0, course, state, yaw_sigma**2, 0.01, t)
        if k == 99:
            assert frame is not None and est.method == "course"
            sigma_first = est.frame_sigma_rad
            z_first = (frame.start_yaw_enu_rad - true_heading) / sigma_first
    estimate = est.heading_estimate()
    assert estimate is not None
    return z_first, (estimate[0] - true_heading) / estimate[1], sigma_first, estimate[1]


def test_frame_heading_refines_over_the_lap_within_its_sigma() -> None:
    """Over 60 drives the normalised heading errors, from the first 100 courses and from a
    whole 60 s lap, have a standard deviation of 1 (within the spread of 60 draws), and the
    lap's sigma is less than 0.6 of the first one's."""
    z = np.array([_frame_heading_z(seed) for seed in range(60)])
    print(f"z std first {z[:, 0].std():.2f} lap {z[:, 1].std():.2f}; "
          f"sigma first {z[:, 2].mean():.4f} lap {z[:, 3].mean():.4f}")
    # The sample std of 60 unit normals lies in [0.75, 1.25] with probability > 0.99.
    assert 0.75 < z[:, 0].std() < 1.25
    assert 0.75 < z[:, 1].std() < 1.25
    assert np.all(z[:, 3] < 0.6 * z[:, 2])


def test_frame_heading_ignores_tight_corners() -> None:
    """Samples taken while the filter turns faster than max_yaw_rate_radps are left out."""
    est = GnssFrameEstimator(LocalTangentFrame(47.0, 8.0, 400.0), None, heading_samples=5,
                             min_speed_mps=1.0, alignment_distance_m=1e9, max_yaw_rate_radps=0.5)
    state = np.array([0.0, 0.0, 0.0, 8.0, 0.0])
    for k in range(10):
        assert est.add(0.0, 0.0, 8.0, 1.0, state, 0.0, 0.8, 0.1 * k) is None
    for k in range(5):
        est.add(0.0, 0.0, 8.0, 0.2, state, 0.0, 0.1, 1.0 + 0.1 * k)
    assert est.frame is not None
    assert est.frame.start_yaw_enu_rad == pytest.approx(0.2)


def test_heading_offset_state_learns_a_course_bias() -> None:
    """A car driving straight at 10 m/s whose yaw a perfect compass re-fixes at 0 every IMU
    sample, its courses (10 Hz, 0.05 rad noise) reading 0.01 rad high (the frame's heading
    error): the offset state (prior sigma 0.02 rad) learns 0.01 to within 3 of its sigmas, its
    sigma falling to about 0.05 / sqrt(300); without the state the offset stays (0, 0)."""
    for with_state in (True, False):
        cfg = AppConfig()
        cfg.mapper.ukf.gnss_heading_state = with_state
        cfg.mapper.ukf.use_gnss_position = False
        ukf = UkfLocaliser(cfg.mapper.ukf, cfg.car)
        ukf.calibrating = False
        ukf.x[3] = 10.0
        ukf.set_gnss_heading_offset(0.0, 0.02)
        rng = np.random.default_rng(3)
        for k in range(1, 6001):
            ukf.predict(ImuSample(0.005 * k, 0.0, 0.0, 9.81, 0.0, 0.0, 0.0))
            ukf.x[2] = 0.0  # the compass fix: the yaw exactly known, its correlations gone
            ukf.P[2, :] = 0.0
            ukf.P[:, 2] = 0.0
            ukf.P[2, 2] = 1e-10
            if k % 20 == 0:
                assert ukf.update_gnss_velocity(10.0, 0.01 + rng.normal(0.0, COURSE_SIGMA_RAD))
        offset, sigma = ukf.gnss_heading_offset
        if not with_state:
            assert (offset, sigma) == (0.0, 0.0)
            continue
        print(f"offset {offset:.5f} +- {sigma:.5f}")
        assert abs(offset - 0.01) < 3.0 * sigma
        assert sigma < 1.5 * COURSE_SIGMA_RAD / math.sqrt(300)


def test_gnss_position_is_turned_by_the_heading_offset() -> None:
    """A position 50 m out along world x, read through a frame turned by 0.02 rad: with the
    offset known (tiny sigma) the update sees no innovation and leaves the position alone."""
    cfg = AppConfig()
    ukf = UkfLocaliser(cfg.mapper.ukf, cfg.car, initial_pose=(50.0, 0.0, 0.0))
    ukf.P[0, 0] = ukf.P[1, 1] = 1.0
    ukf.set_gnss_heading_offset(0.02, 1e-6)
    turned = 50.0 * np.array([math.cos(0.02), math.sin(0.02)])
    assert ukf.update_gnss_position(turned)
    assert ukf.x[0] == pytest.approx(50.0, abs=0.02)
    assert ukf.x[1] == pytest.approx(0.0, abs=0.02)


def test_yaw_integrates_a_ramping_yaw_rate_without_lag() -> None:
    """A yaw rate ramping as 2 t rad/s sampled at 200 Hz: after 1 s the yaw is t^2 = 1 rad to
    1e-9 in the UKF and in the forward prediction (the previous sample's rate, the seed's
    ``yaw += w dt``, is 5 mrad behind)."""
    cfg = AppConfig()
    cfg.mapper.ukf.imu_bias_states = False
    cfg.mapper.ukf.imu_lever_arm = False
    ukf = UkfLocaliser(cfg.mapper.ukf, cfg.car)
    ukf.calibrating = False
    dt = 0.005
    samples = [ImuSample(k * dt, 0.0, 0.0, 9.81, 0.0, 0.0, 2.0 * k * dt) for k in range(201)]
    for s in samples[1:]:
        ukf.predict_input(0.0, 0.0, s.gyro_z_radps, dt)
    assert ukf.x[2] == pytest.approx(1.0, abs=1e-9)
    state, t = predict_forward(np.zeros(6), 0.0, samples, 0.0, np.zeros(2))
    assert t == pytest.approx(1.0)
    assert state[2] == pytest.approx(1.0, abs=1e-9)
