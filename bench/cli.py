"""``python main.py bench NAME``: benchmarks, each a module ``bench/bench_NAME.py``.

A benchmark module defines ``HELP`` (one line), ``add_arguments(parser)`` and
``run(args, config) -> int``. It prints its measurements and, on its last line, the figure its
issue asks for as ``key=value`` (for example ``fps=41.2``), measured against a reference taken in
the same run where a ratio is asked for.
"""

from __future__ import annotations

import argparse
import importlib
import pkgutil
from pathlib import Path
from typing import Any

from orchestrator.config import AppConfig

#: What ``register`` adds: main registers this package only for these (it imports every module).
COMMANDS = ("bench",)


def _benchmarks() -> dict[str, Any]:
    found: dict[str, Any] = {}
    for info in pkgutil.iter_modules([str(Path(__file__).parent)]):
        if info.name.startswith("bench_"):
            found[info.name.removeprefix("bench_")] = importlib.import_module(f"bench.{info.name}")
    return dict(sorted(found.items()))


def register(subparsers: Any, common: argparse.ArgumentParser) -> None:
    """Add ``bench`` with one sub-subcommand per benchmark module."""
    benchmarks = _benchmarks()
    if not benchmarks:
        return
    parser = subparsers.add_parser("bench", parents=[common], help="run a benchmark")
    inner = parser.add_subparsers(dest="benchmark", metavar="NAME", required=True)
    for name, module in benchmarks.items():
        sub = inner.add_parser(name, parents=[common], help=module.HELP)
        module.add_arguments(sub)
        sub.set_defaults(func=_runner(module))


def _runner(module: Any) -> Any:
    def run(args: argparse.Namespace, config: AppConfig) -> int:
        return int(module.run(args, config) or 0)

    return run
