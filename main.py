"""Tier 1: the command line of the driverless stack.

``python main.py`` with no arguments runs ``python main.py sim`` on the default track.

Subcommands are contributed by the packages: a package with a ``cli.py`` that defines
``register(subparsers, common)`` adds its subcommands, so ``--help`` lists only those that exist.
Each registered subcommand sets ``func(args, config) -> int`` on its parser. A ``cli.py`` whose
``register`` is slow (it imports modules) may name its subcommands in ``COMMANDS``; it is then
registered only when one of them, or none known, is asked for. Every subcommand
takes ``--config FILE`` (overrides of the defaults); a bad config stops the program before
anything starts, with one line naming the file, the key and what was expected.
"""

from __future__ import annotations

import os

# Before numpy is imported: the estimators' matrices (at most ~600 x 600) are too small for BLAS
# threads to pay, and on a 2-core car computer threads fight the control loop.
for _name in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_name, "1")

import argparse
import importlib
import importlib.util
import logging
import sys
from collections.abc import Sequence

from common.config import config_to_toml
from common.errors import FsdError
from orchestrator.config import AppConfig, load_config

log = logging.getLogger("main")

#: Packages whose ``cli.py`` may register subcommands, in the order ``--help`` lists them.
COMMAND_PACKAGES = (
    "orchestrator",
    "simulator",
    "sensors",
    "recordings",
    "visualiser",
    "mapper",
    "planner",
    "controller",
    "bench",
    "scale",
)

DEFAULT_COMMAND = "sim"


def _config_command(args: argparse.Namespace, config: AppConfig) -> int:
    if not args.print:
        print("nothing to do: use 'config --print' to show the merged configuration",
              file=sys.stderr)
        return 2
    sys.stdout.write(config_to_toml(config))
    return 0


def build_parser(command: str | None = None, *, complete: bool = True
                 ) -> argparse.ArgumentParser:
    """The whole command line: common options, ``config``, and every package's subcommands.

    With ``command`` (the first argument), a package that declares ``COMMANDS`` without it is left
    out, so that e.g. ``sim`` does not import every benchmark. With None, or a name that no package
    adds (a typo, whose error then lists every real choice), every package is registered.

    A sub-parser may add its options only when it is used (it has ``load_arguments()``, as each
    benchmark's does), so ``--help`` imports no benchmark. ``complete`` loads them all now, for
    code that walks the whole parser; :func:`cli` leaves them to the parse.
    """
    # the common options leave no default of their own: a nested command (``bench NAME``,
    # ``decode KIND``) would otherwise put its default over the value given before NAME
    common = argparse.ArgumentParser(add_help=False)
    common.add_argument("--config", metavar="FILE", default=argparse.SUPPRESS,
                        help="TOML file overriding the default configuration")
    common.add_argument("-v", "--verbose", action="count", default=argparse.SUPPRESS,
                        help="more log output (-vv for debug)")

    parser = argparse.ArgumentParser(
        prog="main.py",
        description="Driverless Formula Student stack. With no subcommand: 'sim' on the default "
        "track.",
        epilog="'COMMAND --help' gives a command's options. Documentation: README.md and docs/ "
        "('mkdocs serve').",
    )
    parser.set_defaults(config=None, verbose=0)
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")

    modules = [importlib.import_module(f"{package}.cli") for package in COMMAND_PACKAGES
               if importlib.util.find_spec(package) is not None
               and importlib.util.find_spec(f"{package}.cli") is not None]
    # Packages that do not declare their commands first: then a command they (or config) add
    # is known, and a declaring package that does not add it can be left out.
    declaring = [module for module in modules if hasattr(module, "COMMANDS")]
    for module in modules if command is None else [m for m in modules if m not in declaring]:
        module.register(sub, common)
    if command is not None:
        known = set(sub.choices) | {"config"}
        for module in declaring:
            if command in module.COMMANDS or command not in known:
                module.register(sub, common)

    config_parser = sub.add_parser("config", parents=[common],
                                   help="show the merged configuration")
    config_parser.add_argument("--print", action="store_true",
                               help="print the merged configuration as TOML")
    config_parser.set_defaults(func=_config_command)
    if complete:
        _load_all(parser)
    return parser


def _load_all(parser: argparse.ArgumentParser) -> None:
    """Add the options of every lazily defined sub-parser under ``parser``."""
    load = getattr(parser, "load_arguments", None)
    if load is not None:
        load()
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for sub in action.choices.values():
                _load_all(sub)


def _setup_logging(verbosity: int) -> None:
    level = logging.WARNING if verbosity <= 0 else logging.INFO if verbosity == 1 else logging.DEBUG
    logging.basicConfig(level=level, format="%(asctime)s %(levelname)s %(name)s: %(message)s")
    # long runs report their progress (a plain line when not on a terminal) at any verbosity
    logging.getLogger("progress").setLevel(min(level, logging.INFO))


def cli(argv: Sequence[str] | None = None) -> int:
    """Run the command line; returns the process exit code."""
    os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
    os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
    argv = list(sys.argv[1:] if argv is None else argv)
    defaulted = not argv or (argv[0].startswith("-") and argv[0] not in ("-h", "--help"))
    parser = build_parser(DEFAULT_COMMAND if defaulted else None if argv[0].startswith("-")
                          else argv[0], complete=False)
    choices: dict[str, argparse.ArgumentParser] = (
        parser._subparsers._group_actions[0].choices  # type: ignore[union-attr,assignment]
    )
    if defaulted:
        if DEFAULT_COMMAND in choices:
            argv = [DEFAULT_COMMAND, *argv]
        else:
            parser.print_help()
            return 0
    args = parser.parse_args(argv)
    if getattr(args, "func", None) is None:
        parser.print_help()
        return 0
    _setup_logging(getattr(args, "verbose", 0))
    try:
        config = load_config(getattr(args, "config", None))
        return int(args.func(args, config) or 0)
    except FsdError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(cli())
