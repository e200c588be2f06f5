"""The UKF's real-car features (issue 17.3): GNSS retiming (latency, UTC), the IMU's mounting
rotation, the GNSS antenna's lever arm and the wheel speed scale; each off by default."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from common.car import CarConfig
from common.conventions import mount_rotation
from common.messages import GpsFix, ImuSample, PoseEstimate, WheelSpeeds
from mapper.config import UkfConfig
from mapper.gnss_timing import GnssTiming
from mapper.imu_mount import ImuMount
from mapper.ukf_localiser import UkfLocaliser


def _fix(t_s: float, utc_s: float) -> GpsFix:
    return GpsFix(t_s, 37.7, -122.4, utc_time_s=utc_s)


def test_timing_off_by_default_keeps_the_fix() -> None:
    cfg = UkfConfig()
    timing = GnssTiming(cfg.gnss_latency_s, cfg.gnss_time_from_utc)
    fix = _fix(12.3, 500.0)
    assert timing.retime(fix) is fix


def test_configured_latency_moves_the_fix_earlier() -> None:
    timing = GnssTiming(0.1, from_utc=False)
    assert timing.retime(_fix(12.3, 500.0)).timestamp_s == pytest.approx(12.2)


def test_utc_timing_removes_the_links_jitter() -> None:
    """Fixes every 0.1 s of UTC arrive 30..90 ms late (random, seed 7) on a clock 1000 s ahead
    of UTC: once the fastest delivery was seen, each is timed at UTC + 1000.03 s, less the
    latency; over midnight the time of day wraps and the times go on."""
    rng = np.random.default_rng(7)
    timing = GnssTiming(0.05, from_utc=True)
    utc = (86400.0 - 2.0 + 0.1 * np.arange(60)) % 86400.0
    delay = rng.uniform(0.03, 0.09, utc.size)
    delay[5] = 0.03
    arrival = 1000.0 + 86400.0 - 2.0 + 0.1 * np.arange(60) + delay
    out = np.array([timing.retime(_fix(t, u)).timestamp_s for t, u in zip(arrival, utc,
                                                                          strict=True)])
    expected = 1000.0 + 86400.0 - 2.0 + 0.1 * np.arange(60) + 0.03 - 0.05
    np.testing.assert_allclose(out[5:], expected[5:], atol=1e-3)  # 100 ppm creep at most
    np.testing.assert_allclose(np.diff(out[5:]), 0.1, atol=2e-4)  # UTC steps (+ creep)
    assert np.all(np.diff(out) > 0.0)
    assert np.all(out[:5] <= arrival[:5] - 0.05 + 1e-9)  # never later than received


def test_aligned_imu_is_passed_through() -> None:
    s = ImuSample(1.0, 0.1, 0.2, 9.8, 0.01, 0.02, 0.03)
    assert ImuMount(CarConfig()).apply(s) is s


def test_mount_rotation_turns_samples_into_the_vehicle_frame() -> None:
    """An IMU pitched 4 deg, rolled 1 deg and yawed -0.6 deg reads gravity and a forward
    acceleration mixed; turned back they are (1.5, 0, 9.81) m/s^2, the yaw rate on z."""
    car = dataclasses.replace(CarConfig(), imu_roll_rad=math.radians(1.0),
                              imu_pitch_rad=math.radians(4.0), imu_yaw_rad=math.radians(-0.6))
    r = mount_rotation(car.imu_roll_rad, car.imu_pitch_rad, car.imu_yaw_rad)
    accel_imu = r.T @ np.array([1.5, 0.0, 9.81])
    gyro_imu = r.T @ np.array([0.0, 0.0, 0.3])
    assert abs(accel_imu[0] - 1.5) > 0.5  # gravity leaks into the IMU's x
    out = ImuMount(car).apply(ImuSample(2.0, *accel_imu, *gyro_imu))
    np.testing.assert_allclose([out.accel_x_mps2, out.accel_y_mps2, out.accel_z_mps2],
                               [1.5, 0.0, 9.81], atol=1e-9)
    np.testing.assert_allclose([out.gyro_x_radps, out.gyro_y_radps, out.gyro_z_radps],
                               [0.0, 0.0, 0.3], atol=1e-12)
    assert out.timestamp_s == 2.0


def _ukf(**changes: float) -> UkfLocaliser:
    cfg = dataclasses.replace(UkfConfig(), **changes)  # type: ignore[arg-type]
    ukf = UkfLocaliser(cfg, CarConfig())
    ukf.calibrating = False
    ukf.reset(PoseEstimate(0.0, 0.0, 0.0, math.pi / 2, 10.0, 0.0, 0.0,
                           np.diag([1.0, 1.0, 1e-4])))
    return ukf


def test_antenna_lever_arm_in_the_position_update() -> None:
    """Car at the origin heading north, antenna 1.5 m ahead: a fix at (0, 1.5) agrees with the
    state (nothing moves); without the lever arm the same fix pulls the car 1.5 m north."""
    with_arm = _ukf(gnss_antenna_x_m=1.5, gnss_position_sigma_m=0.1)
    assert with_arm.update_gnss_position(np.array([0.0, 1.5]))
    assert np.allclose(with_arm.x[:2], 0.0, atol=1e-9)
    without = _ukf(gnss_position_sigma_m=0.1)
    assert without.update_gnss_position(np.array([0.0, 1.5]))
    assert without.x[1] > 1.4


def test_wheel_speed_scale() -> None:
    """Wheels reading 10 m/s with a scale of 1.01: the filter's speed goes to 10.1 m/s."""
    for scale, expected in ((1.0, 10.0), (1.01, 10.1)):
        ukf = _ukf(odometry_speed_scale=scale, odometry_yaw_rate_source="none")
        for _ in range(50):
            ukf.update_odometry(WheelSpeeds(0.0, 10.0, 10.0, 10.0, 10.0))
        assert ukf.x[3] == pytest.approx(expected, abs=0.005)


def test_wheel_scale_learnt_from_steady_gnss_speeds() -> None:
    """GNSS speeds 0.9 % above the wheels' (noise 0.05 m/s, seed 3) at a steady 17 m/s: the
    scale goes to 1.009; pairs while accelerating at 1 m/s^2 with a lagging receiver (0.1 s)
    are left out, so they do not bias it."""
    from mapper.wheel_scale import WheelScaleEstimator

    rng = np.random.default_rng(3)
    est = WheelScaleEstimator(1.0)
    assert est.add(0.0, 17.0, 17.0) == 1.0  # no pair before the first
    t, v = 0.0, 8.0
    for _ in range(100):  # accelerating 1 m/s^2: the receiver reads 0.1 s old speeds
        t += 0.1
        v += 0.1
        est.add(t, 1.009 * (v - 0.1) + rng.normal(0.0, 0.05), v)
    assert est.samples == 0 and est.scale == 1.0
    for _ in range(400):
        t += 0.1
        est.add(t, 1.009 * 17.0 + rng.normal(0.0, 0.05), 17.0)
    assert est.scale == pytest.approx(1.009, abs=0.0005)  # 0.05 / 17 / sqrt(400) = 1.5e-4


def test_receiver_accuracy_from_gst_sets_the_gnss_noise() -> None:
    """A fix written with the receiver's GST sigmas parses back with them; the UKF then fuses
    it with that covariance (in a world frame turned 90 deg from ENU: east noise on world y),
    and without them with the configured sigma."""
    from mapper.ukf_gnss import receiver_covariance
    from sensors.nmea import NmeaParser
    from sensors.nmea_encode import fix_sentences

    parser = NmeaParser(require_checksum=True)
    fixes: list[GpsFix] = []
    for k in range(3):
        fix = GpsFix(10.0 + 0.1 * k, 37.7, -122.4, 30.0, speed_mps=10.0, course_rad=0.5,
                     utc_time_s=1000.0 + 0.1 * k, lat_sigma_m=0.4, lon_sigma_m=0.3)
        for sentence in fix_sentences(fix, 17000.0 * 86400.0):
            fixes += parser.feed(fix.timestamp_s, sentence)
    fixes += parser.flush()
    assert parser.counts["GST"] == 3 and not parser.rejects
    assert (fixes[-1].lat_sigma_m, fixes[-1].lon_sigma_m) == (0.4, 0.3)
    cfg = UkfConfig()
    cov = receiver_covariance(cfg, fixes[-1], math.pi / 2)
    assert cov is not None
    np.testing.assert_allclose(cov, np.diag([0.4**2, 0.3**2]), atol=1e-12)
    assert receiver_covariance(cfg, GpsFix(0.0, 37.7, -122.4), 0.0) is None
    off = dataclasses.replace(cfg, gnss_sigma_from_receiver=False)
    assert receiver_covariance(off, fixes[-1], 0.0) is None
    # 1 m prior, a fix 1 m off: a 0.3 m receiver sigma moves the state ~0.9 m, 5 m ~0.04 m
    for cov_fix, expected in ((np.diag([0.09, 0.09]), 0.917), (None, 1.0 / 26.0)):
        ukf = _ukf()
        ukf.update_gnss_position(np.array([1.0, 0.0]), cov_fix)
        assert ukf.x[0] == pytest.approx(expected, abs=0.01)
