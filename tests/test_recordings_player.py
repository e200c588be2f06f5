"""Player: log-time order across topics and chunks at any rate; pacing never reorders."""

from __future__ import annotations

import threading
from pathlib import Path

import pytest

from common.messages import (
    ActuatorCommand,
    CanFrame,
    GpsFix,
    RawBytes,
    SteeringAngle,
    WheelSpeeds,
)
from recordings import topics
from recordings.config import RecordingConfig
from recordings.player import Player
from recordings.recorder import Recorder


class FakeWallClock:
    """A wall clock that jumps to whatever time it is asked to sleep until."""

    def __init__(self) -> None:
        self.t_s = 100.0
        self.sleeps: list[float] = []

    def now_s(self) -> float:
        return self.t_s

    def sleep_until(self, t_s: float) -> None:
        self.sleeps.append(t_s)
        self.t_s = max(self.t_s, t_s)


def _write_interleaved(path: Path, duration_s: float = 3.0) -> list[tuple[float, str]]:
    """Several topics at different rates, written out of log order, across many chunks.

    Returns the expected (log_time_s, topic) order: by log time, ties in write order.
    """
    written: list[tuple[int, int, str]] = []
    config = RecordingConfig(chunk_duration_s=0.25)
    with Recorder(path, config) as recorder:
        seq = 0
        for i in range(int(duration_s * 100)):
            t = i * 0.01
            recorder.write_raw(RawBytes(t, "gps", b"$G%d\r\n" % i))
            written.append((round(t * 1e9), seq, topics.GPS_NMEA))
            seq += 1
            recorder.write_raw(CanFrame(t + 0.0005, 0x10, bytes([i % 256])))
            written.append((round((t + 0.0005) * 1e9), seq, topics.CAN_FRAME))
            seq += 1
            if i % 5 == 4:
                # An output stamped earlier than the raw units already written: the player
                # must put it back in log-time order.
                t_out = t - 0.03
                recorder.write(topics.COMMAND, ActuatorCommand(t_out, 0.1, 0.0, 0.0), t_out)
                written.append((round(t_out * 1e9), seq, topics.COMMAND))
                seq += 1
            if i % 50 == 0:
                # Same log time as the GPS unit above: ties keep the write order.
                recorder.write("/steer", SteeringAngle(t, 0.01 * i), t)
                written.append((round(t * 1e9), seq, "/steer"))
                seq += 1
    written.sort()
    return [(ns * 1e-9, topic) for ns, _, topic in written]


def test_order_is_log_time_across_topics_as_fast_as_possible(tmp_path: Path) -> None:
    path = tmp_path / "order.mcap"
    expected = _write_interleaved(path)
    got = [(t, topic) for t, topic, _ in Player(path, rate=None)]
    assert got == expected


def test_order_is_the_same_with_pacing(tmp_path: Path) -> None:
    path = tmp_path / "order.mcap"
    _write_interleaved(path)
    flat_out = [(t, topic, repr(m)) for t, topic, m in Player(path)]
    clock = FakeWallClock()
    paced = [(t, topic, repr(m)) for t, topic, m in Player(path, rate=4.0, clock=clock)]
    assert paced == flat_out
    # The pacer asked to wake at start + (t - t0) / rate for every message after the first.
    t0 = flat_out[0][0]
    assert clock.sleeps == pytest.approx([100.0 + (t - t0) / 4.0 for t, _, _ in flat_out[1:]])


def test_real_rate_50_keeps_order(tmp_path: Path) -> None:
    path = tmp_path / "short.mcap"
    expected = _write_interleaved(path, duration_s=0.5)  # 10 ms of wall time at 50x
    got = [(t, topic) for t, topic, _ in Player(path, rate=50.0)]
    assert got == expected


def test_topic_filter_and_foxglove_views_left_out_by_default(tmp_path: Path) -> None:
    path = tmp_path / "filter.mcap"
    _write_interleaved(path, duration_s=0.2)
    with Recorder(tmp_path / "views.mcap") as recorder:
        recorder.write("/wheels", WheelSpeeds(0.0, 1, 1, 1, 1), 0.0)
        recorder.write_gps_fix(GpsFix(0.0, 1.0, 2.0))
    assert {topic for _, topic, _ in Player(tmp_path / "views.mcap")} == {"/wheels"}
    fixes = list(Player(tmp_path / "views.mcap", topics=[topics.FOXGLOVE_GPS]))
    assert len(fixes) == 1 and type(fixes[0][2]).__name__ == "LocationFix"
    only = {topic for _, topic, _ in Player(path, topics=[topics.COMMAND])}
    assert only == {topics.COMMAND}


def test_bad_rate_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "x.mcap"
    with Recorder(path):
        pass
    with pytest.raises(ValueError):
        Player(path, rate=0.0)
    assert list(Player(path)) == []


def _held_recorder(path: Path, queue_length: int
                   ) -> tuple[Recorder, threading.Event, threading.Event]:
    """A recorder whose writer thread, once it takes a message (``taken`` is set), holds it
    until ``gate`` is set."""
    recorder = Recorder(path, RecordingConfig(queue_length=queue_length))
    gate = threading.Event()
    taken = threading.Event()
    handle = recorder._handle

    def slow_handle(item: object) -> None:
        taken.set()
        gate.wait(30.0)
        handle(item)  # type: ignore[arg-type]

    recorder._handle = slow_handle  # type: ignore[method-assign]
    return recorder, gate, taken


def test_recorder_never_blocks_and_counts_drops(tmp_path: Path) -> None:
    recorder, gate, taken = _held_recorder(tmp_path / "drops.mcap", 5)
    path = recorder.path
    assert recorder.write("/steer", SteeringAngle(0.0, 0.0), 0.0)
    assert taken.wait(10.0)  # the writer thread holds the first message
    accepted = [recorder.write("/steer", SteeringAngle(i, 0.0), i) for i in range(1, 100)]
    assert sum(accepted) == 5 and recorder.dropped == 94
    gate.set()
    recorder.close()
    assert recorder.write("/steer", SteeringAngle(200.0, 0.0), 200.0) is False
    assert recorder.dropped == 95
    assert [t for t, _, _ in Player(path)] == [0.0, 1.0, 2.0, 3.0, 4.0, 5.0]


def test_a_batch_of_raw_units_is_one_queue_item_and_its_drops_count_each_unit(
        tmp_path: Path) -> None:
    recorder, gate, taken = _held_recorder(tmp_path / "batches.mcap", 1)
    path = recorder.path

    def batch(t0: float, n: int) -> list[CanFrame]:
        return [CanFrame(t0 + 0.001 * i, 0x20, bytes([i])) for i in range(n)]

    assert recorder.write_raw_many(batch(0.0, 3))
    assert taken.wait(10.0)  # the writer thread holds the first batch's first unit
    assert recorder.write_raw_many(batch(1.0, 4))  # the one queue slot
    assert recorder.write_raw_many(batch(2.0, 7)) is False
    assert recorder.dropped == 7
    assert recorder.write_raw_many([]) and recorder.dropped == 7
    gate.set()
    recorder.close()
    times = [t for t, _, _ in Player(path)]
    assert times == pytest.approx([0.0, 0.001, 0.002, 1.0, 1.001, 1.002, 1.003])


def test_a_bad_unit_in_a_batch_is_counted_and_the_rest_recorded(tmp_path: Path) -> None:
    path = tmp_path / "bad_batch.mcap"
    units = [RawBytes(0.1, "gps", b"$GPGGA\r\n"), RawBytes(float("nan"), "imu", b"\xfa"),
             "not a unit", CanFrame(0.3, 0x100, b"\x01"), RawBytes(0.4, "lidar", b"\xff")]
    with Recorder(path) as recorder:
        assert recorder.write_raw_many(units)  # type: ignore[arg-type]
    assert recorder.errors == 2 and recorder.dropped == 0
    out = list(Player(path))
    assert [topic for _, topic, _ in out] == ["/gps/nmea", "/can/frame", "/lidar/packet"]
    assert [t for t, _, _ in out] == pytest.approx([0.1, 0.3, 0.4], abs=1e-9)


def test_blocking_recorder_loses_nothing(tmp_path: Path) -> None:
    path = tmp_path / "blocking.mcap"
    with Recorder(path, RecordingConfig(queue_length=2), blocking=True) as recorder:
        for i in range(3000):
            recorder.write_raw(CanFrame(i * 0.001, 0x20, i.to_bytes(2, "little")))
    assert recorder.dropped == 0
    frames = [m for _, _, m in Player(path)]
    assert frames == [CanFrame(i * 0.001, 0x20, i.to_bytes(2, "little")) for i in range(3000)]
