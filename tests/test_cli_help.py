"""Every ``--help`` fits a screen and answers at once (issue 43).

``python main.py --help`` imports every package's ``cli.py`` but no benchmark and nothing heavy
(scipy, pygame, matplotlib, Ray, Optuna, cantools): subcommands import those when they run.
That is what keeps it quick (about 0.17 s on an idle 2-core machine); the tests check the
imports, not the clock, which a loaded machine stretches (1.2 s beside two simulations).
``python main.py bench`` with no name lists the benchmarks, one line each.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

import main

ROOT = Path(__file__).resolve().parents[1]
SCREEN_LINES = 40
HEAVY = ("scipy", "pygame", "matplotlib", "ray", "optuna", "cantools", "orchestrator.managers")


def _parsers(parser: argparse.ArgumentParser, path: tuple[str, ...] = ()
             ) -> Iterator[tuple[tuple[str, ...], argparse.ArgumentParser]]:
    yield path, parser
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                yield from _parsers(sub, (*path, name))


def test_every_help_fits_a_screen(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("COLUMNS", "80")
    sizes = {" ".join(path) or "main.py": len(parser.format_help().splitlines())
             for path, parser in _parsers(main.build_parser())}
    assert len(sizes) > 20
    assert {name: n for name, n in sizes.items() if n > SCREEN_LINES} == {}


def _imported(*argv: str) -> set[str]:
    """Modules loaded by ``python main.py ARGV`` (``sys.modules`` at its exit)."""
    code = ("import atexit, json, runpy, sys\n"
            "atexit.register(lambda: sys.stderr.write(\n"
            "    'MODULES ' + json.dumps(sorted(sys.modules))))\n"
            f"sys.argv = ['main.py', *{list(argv)!r}]\n"
            "runpy.run_path('main.py', run_name='__main__')\n")
    proc = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True,
                          timeout=60, check=False)
    assert proc.returncode == 0, proc.stderr[-2000:]
    return set(json.loads(proc.stderr.rsplit("MODULES ", 1)[1]))


@pytest.mark.parametrize("argv", [("--help",), ("sim", "--help"), ("bench", "--help"),
                                  ("bench",), ("config", "--help")])
def test_help_imports_nothing_heavy(argv: tuple[str, ...]) -> None:
    modules = _imported(*argv)
    heavy = sorted(m for m in modules
                   if m.split(".")[0] in HEAVY or m in HEAVY or m.startswith("bench.bench_"))
    assert heavy == []


def test_bench_name_help_imports_that_benchmark_only() -> None:
    modules = _imported("bench", "sim", "--help")
    assert sorted(m for m in modules if m.startswith("bench.bench_")) == ["bench.bench_sim"]


def test_bench_without_a_name_lists_the_benchmarks(capsys: pytest.CaptureFixture[str]) -> None:
    assert main.cli(["bench"]) == 0
    lines = capsys.readouterr().out.strip().splitlines()
    names = sorted(p.stem.removeprefix("bench_") for p in (ROOT / "bench").glob("bench_*.py"))
    listed = sorted(line.split()[0] for line in lines[1:])
    assert listed == names
    assert all(len(line.split(None, 1)) == 2 for line in lines[1:]), lines  # each has its help


def test_bench_name_help_gives_its_options(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exit_info:
        main.cli(["bench", "sim", "--help"])
    assert exit_info.value.code == 0
    out = capsys.readouterr().out
    assert out.startswith("usage: main.py bench sim")
    assert "--seed" in out
