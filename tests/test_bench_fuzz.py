"""``bench fuzz``: seeded mutations, a harness that counts crashes, and a clean run."""

from __future__ import annotations

import logging
import subprocess
import sys
from pathlib import Path

import pytest

from bench.bench_fuzz import _fuzz, _quiet_parsers, _Result, _SafetyNets
from bench.fuzz_corpus import DEFAULT_DATA, bytes_frame, frame_bytes
from bench.fuzz_mutate import Mutator
from bench.fuzz_targets import Target
from common.messages import CanFrame

ROOT = Path(__file__).resolve().parents[1]


def test_mutations_are_seeded() -> None:
    seeds = [b"$GPGGA,143306.00,5546.83315,N,02334.72613,E,1,08,1.28,129.9,M*5B\r\n", b"\xfa" * 40]
    runs = {}
    for name, seed in (("a", 7), ("b", 7), ("c", 8)):
        mutator = Mutator(seed, seeds)
        runs[name] = [mutator.next() for _ in range(200)]
    assert runs["a"] == runs["b"]
    assert runs["a"] != runs["c"]
    assert sum(m not in seeds for m in runs["a"]) > 150  # almost every input is changed


def test_can_frames_round_trip_as_fuzz_input() -> None:
    for frame in (CanFrame(0.0, 0x123, b"\x01\x02"), CanFrame(0.0, 0x1ABCDEF0, b"", True)):
        back = bytes_frame(frame_bytes(frame), 0.0)
        assert (back.arbitration_id, back.data, back.is_extended_id) == (
            frame.arbitration_id, frame.data, frame.is_extended_id)
    assert bytes_frame(b"\x01", 0.0).arbitration_id == 1  # short input: a padded id


class _Fragile(Target):
    """A parser that crashes on a leading 0xFF and hits its safety net on a leading 0xFE."""

    name = "fragile"

    def make(self) -> object:
        return object()

    def run(self, data: bytes) -> None:
        if data[:1] == b"\xff":
            raise KeyError("boom")
        if data[:1] == b"\xfe":
            try:
                raise ZeroDivisionError
            except ZeroDivisionError:
                logging.getLogger("sensors.fragile").exception("safety net")


def test_harness_counts_crashes_and_safety_nets() -> None:
    nets = _SafetyNets()
    result = _Result("fragile")
    mutator = Mutator(0, [b"\xff", b"\xfe", b"\x00"])
    mutator.mutate = lambda data: data  # type: ignore[method-assign]
    with _quiet_parsers(nets):
        _fuzz(_Fragile(), mutator, 300, result, nets, None)
    assert result.inputs == 300
    assert result.uncaught > 50 and result.internal > 50
    assert result.uncaught + result.internal < 300
    assert list(result.crashes) == [f"KeyError at {Path(__file__).name}:"
                                    f"{_Fragile.run.__code__.co_firstlineno + 2}"]


@pytest.mark.skipif(not DEFAULT_DATA.exists(), reason="shared test data missing")
def test_bench_fuzz_runs_every_parser_clean() -> None:
    proc = subprocess.run([sys.executable, "main.py", "bench", "fuzz", "--inputs", "300"],
                          cwd=ROOT, capture_output=True, text=True, timeout=300, check=False)
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.strip().splitlines()
    assert lines[-1] == "uncaught_exceptions=0", proc.stdout
    assert lines[-2] == "internal_errors=0", proc.stdout
    for name in ("nmea", "imu", "can", "lidar", "lidar-hdl32e", "lidar-os1", "camera", "mcap"):
        row = next(line.split() for line in lines if line.split()[:1] == [name])
        assert row[1] == "300"
