"""The recorder in a process of its own (drive's, spawned; sim --realtime's, forked): everything
written arrives, in order; a full list drops and counts; a file that cannot be made is
reported; a killed executive leaves a complete file."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest
from mcap.reader import make_reader

from common.car import CarConfig
from common.messages import CanFrame, GpsFix, RawBytes
from orchestrator.live_recorder import RecorderProcess, recorder_niceness
from recordings import fsd_pb2
from recordings.config import RecordingConfig
from recordings.player import Player
from recordings.reader import RecordingReader

PROJECT = Path(__file__).resolve().parents[1]


def _units(n: int, t0_s: float = 0.0) -> list[RawBytes | CanFrame]:
    out: list[RawBytes | CanFrame] = []
    for i in range(n):
        t = t0_s + i * 0.01
        out.append(RawBytes(t, "gps", b"$GP%05d\r\n" % i))
        out.append(CanFrame(t, 0x100 + i % 7, bytes([i % 256])))
    return out


def _niceness() -> int:
    return os.getpriority(os.PRIO_PROCESS, 0)


def test_what_the_layers_write_is_recorded_in_order(tmp_path: Path) -> None:
    path = tmp_path / "rec.mcap"
    recorder = RecorderProcess(path, RecordingConfig(), _niceness())
    assert recorder.wait_started() is None
    units = _units(300)
    for k in range(0, len(units), 20):  # as the executive hands a tick's units
        assert recorder.write_raw_many(units[k:k + 20])
    fix = GpsFix(3.0, 48.1, 11.5, 500.0, 4, 9, 0.9, 1.0, 2.0, 3.0, 0.1, 0.2)
    assert recorder.write_gps_fix(fix)
    assert recorder.write("/gps/fix", fix, 3.0)
    recorder.close()
    recorder.close()  # idempotent
    assert recorder.dropped == 0 and recorder.errors == 0
    player = Player(path)
    got = [(topic, message) for _, topic, message in player]
    assert not player.recovered
    raw = [m for topic, m in got if topic in ("/gps/nmea", "/can/frame")]
    assert raw == units
    assert ("/gps/fix", fix) in got
    assert recorder.written == len(got) + 1  # + the Foxglove view of the fix
    assert not recorder.write("/gps/fix", fix, 4.0)  # closed: dropped and counted
    assert recorder.dropped == 1


def test_a_forked_recorder_writes_protos_the_car_and_the_metadata(tmp_path: Path) -> None:
    path = tmp_path / "forked.mcap"
    recorder = RecorderProcess(path, RecordingConfig(), _niceness(), car=CarConfig(),
                               metadata={"track": "t", "seed": "3"}, start_method="fork")
    assert recorder.wait_started() is None
    errors = [fsd_pb2.PoseError(timestamp_s=0.1 * i, position_m=0.01 * i) for i in range(5)]
    for error in errors:  # generated protobuf classes do not pickle: they go as bytes
        assert recorder.write_proto("/eval/pose_error", error, error.timestamp_s)
    assert recorder.write_raw_many(_units(10))
    recorder.close()
    assert recorder.dropped == 0 and recorder.errors == 0
    with RecordingReader(path) as reader:
        assert reader.metadata["fsd"] == {"track": "t", "seed": "3"}
    with path.open("rb") as fh:
        got = [fsd_pb2.PoseError.FromString(message.data) for _, _, message
               in make_reader(fh).iter_messages(topics=["/eval/pose_error"])]
    assert got == errors
    assert [m for _, _, m in Player(path)] == _units(10)


def test_more_than_the_queue_holds_is_dropped_and_counted(tmp_path: Path) -> None:
    recorder = RecorderProcess(tmp_path / "small.mcap", RecordingConfig(queue_length=8),
                               _niceness())
    assert recorder.wait_started() is None
    assert not recorder.write_raw_many(_units(5))  # 10 units: more than the whole queue
    assert recorder.write_raw_many(_units(4, 1.0))
    recorder.close()
    assert recorder.dropped == 10
    assert [m for _, _, m in Player(tmp_path / "small.mcap")] == _units(4, 1.0)


def test_a_recording_that_cannot_be_created_is_reported(tmp_path: Path) -> None:
    (tmp_path / "file").write_text("not a folder")
    recorder = RecorderProcess(tmp_path / "file" / "rec.mcap", RecordingConfig(), _niceness())
    error = recorder.wait_started()
    assert error is not None and "cannot create recording" in error
    recorder.close()


def test_the_niceness_is_below_planning_and_above_rendering() -> None:
    assert recorder_niceness(-10) == -2
    assert recorder_niceness(15) == 19


KILLED_EXECUTIVE = textwrap.dedent(
    """
    import os, sys, time
    from common.messages import RawBytes
    from orchestrator.live_recorder import RecorderProcess
    from recordings.config import RecordingConfig

    recorder = RecorderProcess(sys.argv[1], RecordingConfig(), os.getpriority(os.PRIO_PROCESS, 0),
                               start_method=sys.argv[2])
    assert recorder.wait_started() is None
    recorder.write_raw_many([RawBytes(i * 0.01, "gps", b"$GP%05d\\r\\n" % i) for i in range(200)])
    time.sleep(0.5)  # the link sends every 0.05 s
    print("ready", flush=True)
    time.sleep(60)
    """
)


@pytest.mark.parametrize("start_method", ["spawn", "fork"])
def test_a_killed_executive_leaves_a_complete_recording(tmp_path: Path,
                                                        start_method: str) -> None:
    """A forked recorder inherits the executive's end of the link and must close it, or it
    would never see the link close."""
    path = tmp_path / "killed.mcap"
    env = dict(os.environ, PYTHONPATH=str(PROJECT))
    proc = subprocess.Popen([sys.executable, "-c", KILLED_EXECUTIVE, str(path), start_method],
                            stdout=subprocess.PIPE, cwd=PROJECT, env=env, text=True)
    try:
        assert proc.stdout is not None
        assert proc.stdout.readline().strip() == "ready"
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.wait(30)
    # the recorder's process sees its link close and finishes the file (summary, footer)
    indexed = False
    end = time.monotonic() + 60.0
    while not indexed and time.monotonic() < end:
        time.sleep(0.2)
        with RecordingReader(path) as reader:
            indexed = reader.indexed
    assert indexed
    got = [m for _, _, m in Player(path)]
    assert got == [RawBytes(i * 0.01, "gps", b"$GP%05d\r\n" % i) for i in range(200)]
