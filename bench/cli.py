"""``python main.py bench NAME``: benchmarks, each a module ``bench/bench_NAME.py``.

A benchmark module defines ``HELP`` (one line, a string literal), ``add_arguments(parser)`` and
``run(args, config) -> int``. It prints its measurements and, on its last line, the figure its
issue asks for as ``key=value`` (for example ``fps=41.2``), measured against a reference taken in
the same run where a ratio is asked for.

Registration is cheap: each benchmark's ``HELP`` is read from its source without importing it,
and its module is imported (and its options added) only when its parser is used, so
``bench --help`` and ``bench sim`` import one benchmark at most. ``python main.py bench`` with no
name lists them, one line each.
"""

from __future__ import annotations

import argparse
import ast
import importlib
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from orchestrator.config import AppConfig

#: What ``register`` adds: main registers this package only for these.
COMMANDS = ("bench",)

HERE = Path(__file__).parent


def _help_line(path: Path) -> str:
    """The module's ``HELP = "..."`` read from its source (no import)."""
    for node in ast.parse(path.read_text(encoding="utf-8"), str(path)).body:
        if (isinstance(node, ast.Assign) and len(node.targets) == 1
                and isinstance(node.targets[0], ast.Name) and node.targets[0].id == "HELP"
                and isinstance(node.value, ast.Constant) and isinstance(node.value.value, str)):
            return node.value.value
    return ""


def benchmarks() -> dict[str, str]:
    """Every benchmark's name and one-line help, by name."""
    return {path.stem.removeprefix("bench_"): _help_line(path)
            for path in sorted(HERE.glob("bench_*.py"))}


class LazyParser(argparse.ArgumentParser):
    """A sub-parser whose options are added by ``loader`` the first time it is used.

    ``load_arguments()`` adds them at once (for code that walks the whole parser).
    """

    def __init__(self, *args: Any, loader: Callable[[argparse.ArgumentParser], None] | None = None,
                 **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self._loader = loader

    def load_arguments(self) -> None:
        loader, self._loader = self._loader, None
        if loader is not None:
            loader(self)

    def parse_known_args(self, args: Sequence[str] | None = None,  # type: ignore[override]
                         namespace: argparse.Namespace | None = None
                         ) -> tuple[argparse.Namespace, list[str]]:
        self.load_arguments()
        return super().parse_known_args(args, namespace)

    def format_help(self) -> str:
        self.load_arguments()
        return super().format_help()

    def format_usage(self) -> str:
        self.load_arguments()
        return super().format_usage()


def _loader(name: str) -> Callable[[argparse.ArgumentParser], None]:
    def load(parser: argparse.ArgumentParser) -> None:
        module = importlib.import_module(f"bench.bench_{name}")
        doc = (module.__doc__ or "").strip()
        if doc:
            parser.description = doc.split("\n\n")[0]
        module.add_arguments(parser)
        parser.set_defaults(func=_runner(module))

    return load


def register(subparsers: Any, common: argparse.ArgumentParser) -> None:
    """Add ``bench`` with one sub-subcommand per benchmark module (loaded when used)."""
    found = benchmarks()
    if not found:
        return
    parser = subparsers.add_parser(
        "bench", parents=[common], help="run a benchmark (no NAME: list them)",
        description="Each benchmark prints its figure last, as key=value. NAME --help: options.")
    inner = parser.add_subparsers(dest="benchmark", metavar="NAME", parser_class=LazyParser)
    for name, help_line in found.items():
        # func is set now so the parser reads as runnable before it is loaded
        sub = inner.add_parser(name, parents=[common], help=help_line, loader=_loader(name))
        sub.set_defaults(func=_lazy_runner(name))
    parser.set_defaults(func=_list)


def _list(args: argparse.Namespace, config: AppConfig) -> int:
    found = benchmarks()
    width = max(len(name) for name in found)
    print("benchmarks (python main.py bench NAME; NAME --help for its options):")
    for name, help_line in found.items():
        print(f"  {name:<{width}}  {help_line}")
    return 0


def _lazy_runner(name: str) -> Any:
    def run(args: argparse.Namespace, config: AppConfig) -> int:
        module = importlib.import_module(f"bench.bench_{name}")
        return int(module.run(args, config) or 0)

    return run


def _runner(module: Any) -> Any:
    def run(args: argparse.Namespace, config: AppConfig) -> int:
        return int(module.run(args, config) or 0)

    return run
