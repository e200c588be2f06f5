"""Every numeric option of every subcommand is range-checked with a one-line error (issue 19.8).

The parser is walked as a whole: an option typed with a bare ``int`` or ``float`` (unchecked)
fails :func:`test_no_numeric_option_is_unchecked`, so a new subcommand cannot slip one in.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

import main
from common.cli_types import int_in, non_negative_int, positive_float, seed_list, size_wxh
from simulator.faults import fault_spec

ROOT = Path(__file__).resolve().parents[1]


def _subparsers(parser: argparse.ArgumentParser, path: tuple[str, ...] = ()
                ) -> Iterator[tuple[tuple[str, ...], argparse.ArgumentParser]]:
    yield path, parser
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                yield from _subparsers(sub, (*path, name))


def _options() -> list[tuple[tuple[str, ...], argparse.Action]]:
    return [(path, action) for path, parser in _subparsers(main.build_parser())
            for action in parser._actions if action.option_strings or action.dest != "help"]


def test_no_numeric_option_is_unchecked() -> None:
    unchecked = [f"{' '.join(path)} {action.option_strings or action.dest}"
                 for path, action in _options() if action.type in (int, float)]
    assert unchecked == []


def test_the_walk_sees_the_subcommands() -> None:
    paths = {path for path, _ in _subparsers(main.build_parser())}
    for expected in [("sim",), ("replay",), ("drive",), ("record",), ("emulate",), ("render",),
                     ("bench", "sim"), ("bench", "fuzz")]:
        assert expected in paths


# (argv, the option named in the error): each must be refused by the parser (exit 2).
BAD = [
    (["sim", "--laps", "-3"], "--laps"),
    (["sim", "--laps", "0"], "--laps"),
    (["sim", "--laps", "2.5"], "--laps"),
    (["sim", "--seed", "-1"], "--seed"),
    (["sim", "--fault", "estop@-1"], "--fault"),
    (["sim", "--fault", "gps-dropout@3:0"], "--fault"),
    (["replay", "x.mcap", "--rate", "0"], "--rate"),
    (["replay", "x.mcap", "--rate", "-2"], "--rate"),
    (["replay", "x.mcap", "--rate", "nan"], "--rate"),
    (["replay", "x.mcap", "--rate", "inf"], "--rate"),
    (["drive", "--laps", "0"], "--laps"),
    (["drive", "--seconds", "0"], "--seconds"),
    (["drive", "--rt-priority", "100"], "--rt-priority"),
    (["drive", "--rt-priority", "-1"], "--rt-priority"),
    (["record", "--out", "x.mcap", "--seconds", "-5"], "--seconds"),
    (["emulate", "--seconds", "0"], "--seconds"),
    (["emulate", "--seed", "-4"], "--seed"),
    (["emulate", "--rt-priority", "100"], "--rt-priority"),
    (["render", "x.mcap", "--out", "d", "--fps", "0"], "--fps"),
    (["render", "x.mcap", "--out", "d", "--size", "0x720"], "--size"),
    (["render", "x.mcap", "--out", "d", "--size", "big"], "--size"),
    (["bench", "sim", "--duration", "-1"], "--duration"),
    (["bench", "sim", "--seed", "-1"], "--seed"),
    (["bench", "detector", "--sweeps", "0"], "--sweeps"),
    (["bench", "localisation", "--length-m", "0"], "--length-m"),
    (["bench", "nees", "--seeds", "6-1"], "--seeds"),
    (["bench", "nees", "--jobs", "0"], "--jobs"),
    (["bench", "render", "--frames", "0"], "--frames"),
    (["bench", "render", "--loop-seconds", "0"], "--loop-seconds"),
    (["bench", "slam", "--threads", "-1"], "--threads"),
    (["bench", "slam_loops", "--tracks", "0"], "--tracks"),
    (["bench", "trackdrive", "--laps", "-3"], "--laps"),
    (["bench", "fuzz", "--inputs", "0"], "--inputs"),
    (["bench", "fuzz", "--seed", "-1"], "--seed"),
    (["bench", "fuzz", "--parsers", "nmea,bogus"], "--parsers"),
]


@pytest.mark.parametrize(("argv", "option"), BAD, ids=lambda v: " ".join(v) if
                         isinstance(v, list) else v)
def test_out_of_range_is_refused_with_one_line(argv: list[str], option: str,
                                               capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exit_info:
        main.build_parser().parse_args(argv)
    assert exit_info.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    # argparse prints the usage, then exactly one error line naming the option
    assert err[-1].startswith("main.py ") and "error: argument " in err[-1], err
    assert option in err[-1], err[-1]
    assert "Traceback" not in "\n".join(err)


GOOD = [
    (["sim", "--laps", "1", "--seed", "0"], {"laps": 1, "seed": 0}),
    (["replay", "x.mcap", "--rate", "0.5"], {"rate": 0.5}),
    (["drive", "--rt-priority", "0", "--seconds", "1e-3"], {"rt_priority": 0, "seconds": 1e-3}),
    (["render", "x.mcap", "--out", "d", "--size", "640x480", "--fps", "25"],
     {"size": (640, 480), "fps": 25.0}),
    (["bench", "nees", "--seeds", "0-2,7"], {"seeds": [0, 1, 2, 7]}),
    (["bench", "nees"], {"seeds": [1, 2, 3, 4, 5, 6]}),
    (["bench", "render"], {"size": (1280, 720)}),
    # the common options count wherever they stand, before a nested command's NAME too
    (["sim"], {"config": None, "verbose": 0}),
    (["bench", "--config", "f.toml", "trackdrive"], {"config": "f.toml", "verbose": 0}),
    (["bench", "trackdrive", "--config", "f.toml", "-v"], {"config": "f.toml", "verbose": 1}),
    (["decode", "-vv", "--config", "g.toml", "nmea", "x.nmea"], {"config": "g.toml", "verbose": 2}),
]


@pytest.mark.parametrize(("argv", "expected"), GOOD, ids=lambda v: " ".join(v) if
                         isinstance(v, list) else "")
def test_in_range_values_are_accepted(argv: list[str], expected: dict[str, object]) -> None:
    args = main.build_parser().parse_args(argv)
    for key, value in expected.items():
        assert getattr(args, key) == value


@pytest.mark.parametrize("text", ["-1", "1.5", "", "x", "1e3"])
def test_non_negative_int_refuses(text: str) -> None:
    with pytest.raises(argparse.ArgumentTypeError):
        non_negative_int(text)


def test_type_functions_edges() -> None:
    assert int_in(0, 99)("99") == 99
    assert positive_float("1e-9") == 1e-9
    for bad in ("0", "-0", "-1e-9", "nan", "-inf"):
        with pytest.raises(argparse.ArgumentTypeError):
            positive_float(bad)
    assert size_wxh("16X16") == (16, 16)
    assert seed_list("3") == [3]
    for bad in ("", "1-", "a-b", "-1", "3-2"):
        with pytest.raises(argparse.ArgumentTypeError):
            seed_list(bad)
    assert fault_spec("estop@30") == "estop@30"
    with pytest.raises(argparse.ArgumentTypeError, match="unknown kind"):
        fault_spec("bogus@1")


def test_sim_negative_laps_is_refused_before_anything_runs(tmp_path: Path) -> None:
    out = tmp_path / "run"
    proc = subprocess.run([sys.executable, "main.py", "sim", "--laps", "-3", "--no-render",
                           "--out", str(out)], cwd=ROOT, capture_output=True, text=True,
                          timeout=60, check=False)
    assert proc.returncode == 2
    assert "argument --laps: must be an integer >= 1, got '-3'" in proc.stderr
    assert "Traceback" not in proc.stderr
    assert not out.exists()


def test_generated_track_with_negative_seed_is_one_line(tmp_path: Path) -> None:
    proc = subprocess.run([sys.executable, "main.py", "sim", "--track", "gen:-3", "--no-render",
                           "--no-record", "--out", str(tmp_path / "run")], cwd=ROOT,
                          capture_output=True, text=True, timeout=60, check=False)
    assert proc.returncode == 2
    assert "Traceback" not in proc.stderr
    assert proc.stderr.strip().splitlines()[-1].startswith("error: track 'gen:-3'")


def _commands(parser: argparse.ArgumentParser) -> set[str]:
    return {path[0] for path, _ in _subparsers(parser) if len(path) == 1}


def test_a_known_command_leaves_out_the_packages_that_declare_other_commands() -> None:
    everything = _commands(main.build_parser())
    assert {"sim", "bench", "drive", "campaign", "config"} <= everything
    assert _commands(main.build_parser("sim")) == everything - {"bench"}
    assert _commands(main.build_parser("bench")) == everything
    # a typo is told against every real choice, bench's included
    assert _commands(main.build_parser("bnch")) == everything


def test_sim_does_not_import_the_benchmarks() -> None:
    code = ("import sys, main; main.build_parser('sim'); "
            "print(sorted(m for m in sys.modules if m.startswith('bench.bench_')))")
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True,
                         check=True).stdout
    assert out.strip() == "[]"
