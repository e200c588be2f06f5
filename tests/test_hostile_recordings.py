"""Hostile bytes into the recording reader (issue 19.4): truncated, bit-flipped, garbage MCAP.

``info`` and the player of ``replay`` read whatever can be read: a file that is not a recording
at all is one :class:`RecordingError` line; a damaged one gives what was complete before the
damage (never a message that was not written) and counts what it skipped. Property-based,
derandomized, a few hundred examples.
"""

from __future__ import annotations

import math
import tempfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from common.errors import RecordingError
from common.messages import (
    ActuatorCommand,
    AsState,
    CameraCones,
    CanFrame,
    ConeColour,
    ConeDetection,
    GpsFix,
    ImuSample,
    LidarPoints,
    RawBytes,
)
from recordings.config import RecordingConfig
from recordings.info import info
from recordings.player import Player
from recordings.recorder import Recorder

HOSTILE = settings(max_examples=200, deadline=None, derandomize=True, database=None,
                   suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])


def _write_recording(path: Path) -> None:
    config = RecordingConfig(chunk_duration_s=0.05, foxglove=False)
    with Recorder(path, config, blocking=True, metadata={"track": "hostile"}) as recorder:
        for i in range(40):
            t = 0.01 * i
            recorder.write_raw(RawBytes(t, "gps", b"$GPGGA,%06d,5546.8,N,02334.7,E*00\r\n" % i))
            recorder.write_raw(CanFrame(t, 0x100 + i % 3, bytes([i % 256] * 8)))
            recorder.write("/imu", ImuSample(t, 0.1, 0.2, 9.8, 0.0, 0.0, 0.01 * i), t)
            if i % 8 == 0:
                recorder.write("/gps/fix", GpsFix(t, 55.78, 23.57), t)
                recorder.write("/camera/cones", CameraCones(
                    t, (ConeDetection(t, 5.0, 1.5, ConeColour.BLUE),), i), t)
                recorder.write("/lidar/points", LidarPoints(
                    t, np.ones((3, 4)), np.full(3, t), np.arange(3)), t)
                recorder.write("/command", ActuatorCommand(t, 0.2, 0.0, 0.05, AsState.DRIVING), t)


@pytest.fixture(scope="module")
def recording() -> bytes:
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "seed.mcap"
        _write_recording(path)
        return path.read_bytes()


def _read(data: bytes) -> tuple[dict | None, list[tuple[float, str, object]], int]:
    """``info`` (None when the file is refused) and what the player yields, of ``data``."""
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "x.mcap"
        path.write_bytes(data)
        try:
            summary = info(path)
        except RecordingError as exc:
            assert str(path) in str(exc) and "\n" not in str(exc)
            with pytest.raises(RecordingError):
                Player(path)
            return None, [], 0
        player = Player(path)
        played = list(player)
        return summary, played, player.decode_errors


def _key(entry: tuple[float, str, object]) -> tuple[float, str, str]:
    t, topic, message = entry
    return t, topic, repr(message)


def test_the_seed_recording_reads_whole(recording: bytes) -> None:
    summary, played, errors = _read(recording)
    assert summary is not None and not summary["recovered"]
    assert len(played) == summary["message_count"] == 40 * 3 + 5 * 4
    assert errors == 0


@HOSTILE
@given(st.floats(0.0, 1.0))
def test_truncated_recording_gives_what_was_complete(recording: bytes, fraction: float) -> None:
    whole = {_key(e) for e in _read(recording)[1]}
    summary, played, errors = _read(recording[:int(len(recording) * fraction)])
    if summary is None:
        return  # cut inside the magic: not a recording, said in one line
    assert {_key(e) for e in played} <= whole  # nothing that was not written
    assert errors == 0
    assert summary["message_count"] == len(played)


@HOSTILE
@given(st.lists(st.tuples(st.floats(0.0, 1.0, exclude_max=True), st.integers(0, 7)),
                min_size=1, max_size=8))
def test_bit_flipped_recording_never_crashes(recording: bytes,
                                             flips: list[tuple[float, int]]) -> None:
    data = bytearray(recording)
    for where, bit in flips:
        data[int(where * len(data))] ^= 1 << bit
    summary, played, errors = _read(bytes(data))
    if summary is not None:
        # what info counts, the player yields or counts as undecodable: nothing vanishes
        assert len(played) + errors == summary["message_count"]
        for t, _topic, _message in played:
            assert math.isfinite(t) and t >= 0.0


@HOSTILE
@given(st.binary(max_size=3000), st.booleans())
def test_garbage_is_refused_in_one_line_or_read_as_empty(junk: bytes, magic: bool) -> None:
    data = (b"\x89MCAP0\r\n" if magic else b"") + junk
    summary, played, errors = _read(data)
    if summary is not None:
        assert data.startswith(b"\x89MCAP0\r\n")
        assert summary["message_count"] == len(played) + errors


@HOSTILE
@given(st.integers(8, 4000), st.binary(min_size=1, max_size=64))
def test_spliced_garbage_inside_a_recording(recording: bytes, at: int, junk: bytes) -> None:
    data = recording[:at] + junk + recording[at:]
    summary, played, errors = _read(data)
    assert summary is not None  # the magic is intact: always a (recovered) recording
    assert summary["recovered"]
    assert len(played) + errors == summary["message_count"]
