"""A mapper behind its sensors predicts two IMU samples at a time (mapper/imu_coalesce.py)."""

from __future__ import annotations

import pytest

from common.messages import ImuSample, WheelSpeeds
from mapper.imu_coalesce import coalesce_imu


def _imu(t: float, gz: float) -> tuple[str, ImuSample]:
    return "imu", ImuSample(t, 1.0, 2.0 * t, 9.81, 0.0, 0.0, gz)


def _wheels(t: float) -> tuple[str, WheelSpeeds]:
    return "odometry", WheelSpeeds(t, 5.0, 5.0, 5.0, 5.0)


def test_a_short_backlog_is_predicted_sample_by_sample() -> None:
    ready = [_imu(0.005 * k, 0.1) for k in range(20)]  # 95 ms of samples
    out, merged = coalesce_imu(ready, 0.15)
    assert out == ready and merged == 0
    assert coalesce_imu([_imu(0.005 * k, 0.1) for k in range(100)], 0.0)[1] == 0  # off


def test_a_long_backlog_merges_consecutive_pairs_at_the_later_time_with_their_mean() -> None:
    """0.3 s of 200 Hz samples with wheel speeds between: each two IMU samples with nothing
    between them become one at the later one's time, with the mean of their readings; the
    other readings keep their place, and the order of time holds."""
    ready = []
    for k in range(60):
        ready.append(_imu(0.005 * k, 0.01 * k))
        if k % 5 == 4:
            ready.append(_wheels(0.005 * k + 0.001))
    out, merged = coalesce_imu(ready, 0.15)
    times = [r.timestamp_s for _, r in out]
    assert times == sorted(times)
    assert [r for _, r in out if isinstance(r, WheelSpeeds)] == [
        r for _, r in ready if isinstance(r, WheelSpeeds)]
    imu = [r for _, r in out if isinstance(r, ImuSample)]
    # runs of 5 samples between wheel speeds: 2 pairs and 1 left alone each
    assert merged == 24 and len(imu) == 60 - 24
    first = imu[0]
    assert first.timestamp_s == pytest.approx(0.005)
    assert first.gyro_z_radps == pytest.approx(0.005)
    assert first.accel_y_mps2 == pytest.approx(0.005)
    assert first.accel_z_mps2 == pytest.approx(9.81)
