"""A recording survives SIGKILL up to its last complete chunk; info explains bad files."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from common.errors import RecordingError
from common.messages import CanFrame, RawBytes
from recordings import cli
from recordings.info import info
from recordings.player import Player
from recordings.reader import RecordingReader
from recordings.recorder import Recorder

PROJECT = Path(__file__).resolve().parents[1]

WRITER = textwrap.dedent(
    """
    import sys, time
    from common.messages import RawBytes, CanFrame
    from recordings.recorder import Recorder
    from recordings.config import RecordingConfig

    recorder = Recorder(sys.argv[1], RecordingConfig(chunk_duration_s=1.0))
    # Five seconds of log time, written at once: chunks close on log time.
    for i in range(500):
        t = i * 0.01
        recorder.write_raw(RawBytes(t, "gps", b"$GP%05d\\r\\n" % i))
        recorder.write_raw(CanFrame(t, 0x100 + i % 7, bytes([i % 256])))
    while recorder.queued:
        time.sleep(0.01)
    # Nothing new for longer than a chunk's duration: the open chunk closes on the wall clock.
    time.sleep(1.6)
    print("ready", flush=True)
    # These stay in an open chunk when the kill comes.
    for i in range(500, 520):
        recorder.write_raw(RawBytes(i * 0.01, "gps", b"$GP%05d\\r\\n" % i))
    time.sleep(60)
    """
)


def _expected(n: int) -> list[tuple[str, object]]:
    out: list[tuple[str, object]] = []
    for i in range(n):
        t = i * 0.01
        out.append(("/gps/nmea", RawBytes(t, "gps", b"$GP%05d\r\n" % i)))
        out.append(("/can/frame", CanFrame(t, 0x100 + i % 7, bytes([i % 256]))))
    return out


@pytest.fixture(scope="module")
def killed_recording(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("kill") / "killed.mcap"
    env = dict(os.environ, PYTHONPATH=str(PROJECT))
    proc = subprocess.Popen(
        [sys.executable, "-c", WRITER, str(path)], stdout=subprocess.PIPE, cwd=PROJECT, env=env,
        text=True,
    )
    try:
        assert proc.stdout is not None
        line = proc.stdout.readline()
        assert line.strip() == "ready", f"writer failed: {line!r}"
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.wait(30)
    assert proc.returncode == -signal.SIGKILL
    return path


def test_sigkilled_recording_reads_up_to_its_last_chunk(killed_recording: Path) -> None:
    player = Player(killed_recording)
    got = [(topic, message) for _, topic, message in player]
    assert player.recovered
    # Everything written before the pause is there, exactly and in order.
    assert got[:1000] == _expected(500)
    assert len(got) in (1000, 1020)


def test_info_on_a_sigkilled_recording(killed_recording: Path) -> None:
    summary = info(killed_recording)
    assert summary["recovered"] is True
    assert "footer" in summary["note"]
    assert summary["message_count"] >= 1000
    assert summary["duration_s"] >= 4.99
    assert summary["topics"]["/gps/nmea"]["rate_hz"] == pytest.approx(100.0, rel=1e-6)
    assert summary["topics"]["/can/frame"]["count"] == 500


def _complete(tmp_path: Path) -> Path:
    path = tmp_path / "complete.mcap"
    with Recorder(path) as recorder:
        for i in range(600):
            t = i * 0.01
            recorder.write_raw(RawBytes(t, "gps", b"$GP%05d\r\n" % i))
            recorder.write_raw(CanFrame(t, 0x100 + i % 7, bytes([i % 256])))
        recorder.write_raw(RawBytes(9.0, "gps", b"$late\r\n"))  # a gap of 3 s
    return path


def test_info_on_a_complete_file(tmp_path: Path) -> None:
    path = _complete(tmp_path)
    with RecordingReader(path) as reader:
        assert reader.indexed and not reader.recovered
    summary = info(path)
    assert summary["recovered"] is False and summary["note"] == ""
    assert summary["message_count"] == 1201
    assert summary["duration_s"] == pytest.approx(9.0)
    assert summary["chunk_count"] >= 6  # closed every second of log time
    gps = summary["topics"]["/gps/nmea"]
    assert gps["max_gap_s"] == pytest.approx(3.01)
    assert summary["gap_count"] == 1
    assert summary["gaps"][0]["topic"] == "/gps/nmea"
    assert summary["gaps"][0]["gap_s"] == pytest.approx(3.01)


@pytest.mark.parametrize("fraction", [0.3, 0.6, 0.95, 0.999])
def test_truncated_file_is_recovered(tmp_path: Path, fraction: float) -> None:
    source = _complete(tmp_path)
    data = source.read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: int(len(data) * fraction)])
    everything = [(t, topic, repr(m)) for t, topic, m in Player(source)]
    player = Player(cut)
    got = [(t, topic, repr(m)) for t, topic, m in player]
    assert player.recovered
    assert got == everything[: len(got)]  # a prefix, nothing invented
    summary = info(cut)
    assert summary["recovered"] is True and summary["message_count"] == len(got)
    if fraction >= 0.6:
        assert len(got) > 0


def test_corrupt_chunk_in_a_complete_file_is_skipped(tmp_path: Path) -> None:
    source = _complete(tmp_path)
    with RecordingReader(source) as reader:
        offsets = sorted(u.offset for u in reader._units)
    data = bytearray(source.read_bytes())
    data[offsets[2] + 60] ^= 0xFF  # inside the compressed data of the third chunk
    source.write_bytes(bytes(data))
    summary = info(source)
    assert summary["recovered"] is True and summary["bad_chunks"] == 1
    assert 0 < summary["message_count"] < 1201


def test_garbage_and_missing_files(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    garbage = tmp_path / "garbage.mcap"
    garbage.write_bytes(np.random.default_rng(1).bytes(5000))
    with pytest.raises(RecordingError, match="not an MCAP"):
        info(garbage)
    with pytest.raises(RecordingError):
        info(tmp_path / "missing.mcap")
    empty = tmp_path / "empty.mcap"
    empty.write_bytes(b"")
    with pytest.raises(RecordingError):
        info(empty)
    magic_then_junk = tmp_path / "junk.mcap"
    magic_then_junk.write_bytes(b"\x89MCAP0\r\n" + np.random.default_rng(2).bytes(3000))
    summary = info(magic_then_junk)
    assert summary["recovered"] is True and summary["message_count"] == 0


def _run_info(path: Path, *extra: str) -> int:
    import argparse

    parser = argparse.ArgumentParser()
    sub = parser.add_subparsers()
    cli.register(sub, argparse.ArgumentParser(add_help=False))
    args = parser.parse_args(["info", str(path), *extra])
    return int(args.func(args, None))


def test_info_cli(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    source = _complete(tmp_path)
    assert _run_info(source) == 0
    out = capsys.readouterr().out
    assert "/gps/nmea" in out and "recovered: no" in out
    assert _run_info(source, "--json") == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["message_count"] == 1201
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(source.read_bytes()[: source.stat().st_size // 2])
    assert _run_info(cut, "--json") == 0
    assert json.loads(capsys.readouterr().out)["recovered"] is True
    garbage = tmp_path / "garbage.mcap"
    garbage.write_bytes(b"hello, not a recording\n")
    assert _run_info(garbage) == 1
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "not an MCAP" in err
    junk = tmp_path / "junk.mcap"
    junk.write_bytes(b"\x89MCAP0\r\n\x01\x02")
    assert _run_info(junk) == 1
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "nothing readable" in err


def _on_disk_until(path: Path, tmp_path: Path, done: object, deadline_s: float = 30.0
                   ) -> list[int]:
    """Log times (ns) of the messages in a copy of ``path`` as it is on disk now (what a
    SIGKILL would leave), read again until ``done(times)`` or the deadline (no timing is
    asserted: the deadline only keeps a broken writer from hanging the test)."""
    import shutil
    import time

    end = time.monotonic() + deadline_s
    while True:
        copy = tmp_path / "copy.mcap"
        shutil.copyfile(path, copy)
        with RecordingReader(copy) as reader:
            times = [m.log_time_ns for m in reader.iter_messages()]
        if done(times) or time.monotonic() > end:  # type: ignore[operator]
            return times
        time.sleep(0.02)


def test_default_chunks_lose_at_most_half_a_second_of_log_time(tmp_path: Path) -> None:
    """Issue 19.5: with the default configuration, once the writer has taken the messages the
    file on disk (what SIGKILL leaves) holds all but at most the last 0.5 s of log time, by the
    log-time rule alone (the wall clock is frozen); the open chunk closes on the wall clock."""
    from recordings.config import RecordingConfig

    assert RecordingConfig().chunk_duration_s <= 0.5
    wall = [100.0]
    path = tmp_path / "live.mcap"
    recorder = Recorder(path, wall_clock_s=lambda: wall[0])
    try:
        last_ns = round(4.99 * 1e9)
        for i in range(500):
            recorder.write_raw(RawBytes(i * 0.01, "gps", b"$GP%05d\r\n" % i))
        # once the writer has taken (and written) them all: a busy machine may hold it back
        _on_disk_until(path, tmp_path, lambda t: recorder.written >= 500)
        times = _on_disk_until(path, tmp_path, lambda t: bool(t) and t[-1] >= last_ns - 5e8)
        assert times and times[-1] >= last_ns - 0.5e9, times[-1:] if times else "nothing on disk"
        assert times == sorted(times) and len(times) == len(set(times))
        assert recorder.written == 500
        # Nothing new arrives: the open chunk closes once it has been open chunk_duration_s.
        wall[0] += 1.0
        times = _on_disk_until(path, tmp_path, lambda t: len(t) == 500)
        assert len(times) == 500 and times[-1] == last_ns
    finally:
        recorder.close()
