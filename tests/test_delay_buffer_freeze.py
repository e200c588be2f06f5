"""The delay buffer when the stack itself was not run: nothing pushed or popped for 1.4 s (a
loaded machine stopped drive's processes, issue 19), then the sensors' backlog in a burst. The
IMU and LiDAR stamp their readings with their own clocks, so their backlog carries the times it
was made at; the wheel speeds are stamped as they arrive. Their backlog is applied in the order
it was made, not dropped as late, and a sensor that is truly dead still stops holding the
filter back."""

from __future__ import annotations

from common.messages import ImuSample, LidarCones, Reading, WheelSpeeds
from mapper.delay_buffer import DelayBuffer

MAX_DELAY_S = 0.3
FREEZE_S = 1.4


def _imu(t: float) -> ImuSample:
    return ImuSample(t, 0.0, 0.0, 9.81, 0.0, 0.0, 0.0)


def _run(freeze_gap_s: float) -> tuple[DelayBuffer, list[Reading]]:
    """1 s of IMU (200 Hz), wheels (100 Hz) and LiDAR (10 Hz) pushed and popped every 10 ms,
    a freeze of 1.4 s, then: the wheels' backlog stamped on arrival, the IMU's and LiDAR's
    with the times they were made, as drive's readers deliver them, then on time again."""
    buf = DelayBuffer(MAX_DELAY_S, freeze_gap_s)
    out: list[Reading] = []
    for k in range(1, 101):
        now = k * 0.01
        buf.push("wheels", WheelSpeeds(now, 7.0, 7.0, 7.0, 7.0), now)
        for j in (2 * k - 1, 2 * k):
            buf.push("imu", _imu(j * 0.005), now)
        if k % 10 == 0:
            buf.push("lidar", LidarCones(now - 0.01, ()), now)
        out += [r for _, r in buf.pop_ready(now)]
    resume = 1.0 + FREEZE_S
    for j in range(10):  # the CAN backlog, read in 10 ms
        now = resume + 0.001 * j
        buf.push("wheels", WheelSpeeds(now, 7.0, 7.0, 7.0, 7.0), now)
    out += [r for _, r in buf.pop_ready(resume + 0.01)]
    now = resume + 0.02
    for j in range(201, 481):  # the IMU's backlog: 1.0 .. 2.4 s, its own times
        buf.push("imu", _imu(j * 0.005), now)
    out += [r for _, r in buf.pop_ready(now)]
    now = resume + 0.2  # the LiDAR's backlog, parsed last
    for j in range(11, 25):
        buf.push("lidar", LidarCones(j * 0.1 - 0.01, ()), now)
    out += [r for _, r in buf.pop_ready(now)]
    for k in range(1, 101):  # on time again
        now = resume + 0.2 + k * 0.01
        buf.push("wheels", WheelSpeeds(now, 7.0, 7.0, 7.0, 7.0), now)
        buf.push("imu", _imu(now), now)
        out += [r for _, r in buf.pop_ready(now)]
    return buf, out


def test_the_backlog_after_a_freeze_is_applied_in_order() -> None:
    buf, out = _run(0.5)
    assert buf.freezes == 1
    assert not buf.late  # nothing dropped
    times = [r.timestamp_s for r in out]
    assert times == sorted(times)
    assert sum(isinstance(r, LidarCones) for r in out) == 10 + 14
    assert sum(isinstance(r, ImuSample) for r in out) == 200 + 280 + 100

    # Without: the wheels' burst moved the horizon past the backlog, which was dropped.
    old, _ = _run(float("inf"))
    assert old.freezes == 0
    assert old.late["imu"] >= 200 and old.late["lidar"] >= 10


def test_a_dead_sensor_still_lets_go_after_a_freeze() -> None:
    """The camera, silent since before the freeze, holds the filter back no longer than
    max_delay_s after the trail is paid back (1.4 s at the clock's pace)."""
    buf = DelayBuffer(MAX_DELAY_S, 0.5)
    for k in range(1, 101):
        now = k * 0.01
        buf.push("imu", _imu(now), now)
        if k == 50:
            buf.push("camera", LidarCones(now, ()), now)  # its last reading
        buf.pop_ready(now)
    now = 1.0 + FREEZE_S
    for k in range(0, 200):
        now = 2.4 + k * 0.01
        buf.push("imu", _imu(now), now)
        buf.pop_ready(now)
    assert buf.horizon(now) >= now - MAX_DELAY_S - 1e-9
