"""A mapper behind its sensors catches up: two IMU samples become one prediction.

Each IMU sample is one prediction of the filter (the UKF's sigma points, the EKF's Jacobians),
the mapper's largest cost. When ``drive``'s executive process falls behind on a busy computer,
the readings of a few hundred milliseconds arrive at once; predicting each sample keeps each
update as long as the backlog it took, and the map stays behind (issue 19: map updates of
0.2-0.35 s, each with 130 readings, and the controller's pose 0.5 s old). Merging each two
consecutive samples of such a backlog into one at the later one's time, with their mean
readings, halves the predictions: the filter steps 10 ms at a time instead of 5 ms, with the
mean input over the step (as a 100 Hz IMU would give it).

Off where ``backlog_s`` is 0 (the simulator and replay, whose outputs stay as they were).
"""

from __future__ import annotations

from collections.abc import Sequence

from common.messages import ImuSample, Reading


def _mean(a: ImuSample, b: ImuSample) -> ImuSample:
    """One sample at ``b``'s time with the mean of ``a``'s and ``b``'s readings."""
    return ImuSample(b.timestamp_s,
                     0.5 * (a.accel_x_mps2 + b.accel_x_mps2),
                     0.5 * (a.accel_y_mps2 + b.accel_y_mps2),
                     0.5 * (a.accel_z_mps2 + b.accel_z_mps2),
                     0.5 * (a.gyro_x_radps + b.gyro_x_radps),
                     0.5 * (a.gyro_y_radps + b.gyro_y_radps),
                     0.5 * (a.gyro_z_radps + b.gyro_z_radps))


def coalesce_imu(ready: Sequence[tuple[str, Reading]], backlog_s: float
                 ) -> tuple[list[tuple[str, Reading]], int]:
    """``ready`` (stream, reading) in time order, with each two consecutive IMU samples (no
    other reading between them) merged when the IMU samples in it span more than
    ``backlog_s`` (s; 0: never); the readings and how many merges were made."""
    if backlog_s <= 0.0:  # the simulator's and replay's every tick: nothing to look at
        return list(ready), 0
    imu_times = [r.timestamp_s for _, r in ready if isinstance(r, ImuSample)]
    if len(imu_times) < 2 or imu_times[-1] - imu_times[0] <= backlog_s:
        return list(ready), 0
    out: list[tuple[str, Reading]] = []
    held: tuple[str, ImuSample] | None = None
    merged = 0
    for stream, reading in ready:
        if isinstance(reading, ImuSample):
            if held is None:
                held = (stream, reading)
                continue
            out.append((stream, _mean(held[1], reading)))
            held = None
            merged += 1
            continue
        if held is not None:
            out.append(held)
            held = None
        out.append((stream, reading))
    if held is not None:
        out.append(held)
    return out, merged
