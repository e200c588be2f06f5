"""Hostile bytes: mutated real captures through every parser, uncaught exceptions counted.

``python main.py bench fuzz --inputs N`` builds each parser's seed inputs from the real captures
in ``../shared/data`` (read at run time: :mod:`bench.fuzz_corpus`), mutates them
(:mod:`bench.fuzz_mutate`, seeded by ``--seed``) and feeds N inputs to each parser the way the
stack feeds it (:mod:`bench.fuzz_targets`): NMEA, IMU, CAN through the DBC, VLP-16 datagrams,
camera datagrams and MCAP recordings (``info`` and ``replay``'s player).

Per parser it prints the inputs, the rejections the parsers counted, the *clear errors* (a file
that is not a recording at all: one-line RecordingError, by design), the *internal errors* (a
parser's last-resort safety net caught something: logged with a traceback, counted as a
rejection, but a bug all the same) and the *uncaught exceptions* (a crash: the receiver thread
would die), with the first traceback of each distinct crash. The last line is
``uncaught_exceptions=<total over every parser>`` (target 0); internal errors are reported
beside it and must be 0 too. A progress bar shows on a terminal.
"""

from __future__ import annotations

import argparse
import contextlib
import logging
import sys
import time
import traceback
from collections import Counter
from collections.abc import Iterator
from pathlib import Path

from bench.fuzz_corpus import DEFAULT_DATA, SEEDS
from bench.fuzz_mutate import Mutator
from bench.fuzz_targets import Target, make_targets
from common.cli_types import non_negative_int, positive_int
from orchestrator.config import AppConfig

HELP = "mutated real captures through every parser: uncaught exceptions"
PARSERS = tuple(SEEDS)
SHOWN_CRASHES = 3
"""Distinct crashes printed in full per parser."""
LOGGERS = ("sensors", "recordings", "bench", "common")
"""The packages whose log output is muted (and watched for tracebacks) while fuzzing."""


def _parser_list(text: str) -> list[str]:
    names = [n.strip() for n in text.split(",") if n.strip()]
    unknown = [n for n in names if n not in PARSERS]
    if not names or unknown:
        raise argparse.ArgumentTypeError(
            f"must be a comma-separated list of {', '.join(PARSERS)}, got {text!r}")
    return names


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``bench fuzz``."""
    parser.add_argument("--inputs", type=positive_int, default=100_000,
                        help="mutated inputs per parser (default 100000)")
    parser.add_argument("--seed", type=non_negative_int, default=0,
                        help="seed of the mutations (default 0)")
    parser.add_argument("--parsers", type=_parser_list, default=list(PARSERS),
                        help=f"comma-separated subset of {','.join(PARSERS)}")
    parser.add_argument("--data", type=Path, default=DEFAULT_DATA,
                        help="the shared data folder (default ../shared/data)")


class _SafetyNets(logging.Handler):
    """Counts log records that carry a traceback: a parser's last-resort catch fired."""

    # (records without one are the parsers' ordinary, rate-limited rejection notes: dropped)

    def __init__(self) -> None:
        super().__init__(logging.ERROR)
        self.count = 0
        self.first: list[str] = []

    def emit(self, record: logging.LogRecord) -> None:
        if record.exc_info:
            self.count += 1
            if len(self.first) < SHOWN_CRASHES:
                self.first.append(f"{record.name}: {record.getMessage()}\n"
                                  + "".join(traceback.format_exception(*record.exc_info)))


class _Result:
    def __init__(self, name: str) -> None:
        self.name = name
        self.inputs = 0
        self.uncaught = 0
        self.clear = 0
        self.internal = 0
        self.rejected = 0
        self.seconds = 0.0
        self.crashes: Counter[str] = Counter()
        self.tracebacks: dict[str, str] = {}

    def crash(self, exc: BaseException) -> None:
        self.uncaught += 1
        tb = traceback.extract_tb(exc.__traceback__)
        where = tb[-1] if tb else None
        key = (f"{type(exc).__name__} at {Path(where.filename).name}:{where.lineno}"
               if where else type(exc).__name__)
        self.crashes[key] += 1
        if key not in self.tracebacks:
            self.tracebacks[key] = "".join(traceback.format_exception(exc))


def _fuzz(target: Target, mutator: Mutator, inputs: int, result: _Result,
          nets: _SafetyNets, bar: object) -> None:
    seeds = mutator.seeds
    before = nets.count
    t0 = time.perf_counter()
    for i in range(inputs):
        data = mutator.mutate(seeds[i % len(seeds)]) if target.ordered else mutator.next()
        try:
            target.feed(data)
        except target.clear_errors:
            result.clear += 1
        except Exception as exc:  # noqa: BLE001 (that is what is being counted)
            result.crash(exc)
        if bar is not None:
            bar.update(1)  # type: ignore[attr-defined]
    try:
        target.close()
    except Exception as exc:  # noqa: BLE001
        result.crash(exc)
    result.inputs = inputs
    result.seconds = time.perf_counter() - t0
    result.rejected = target.rejected()
    result.internal = nets.count - before


def run(args: argparse.Namespace, config: AppConfig) -> int:
    """Fuzz every chosen parser; print the table and ``uncaught_exceptions=<n>``."""
    del config
    data_dir: Path = args.data
    targets = make_targets(data_dir)
    nets = _SafetyNets()
    bar = None
    if sys.stderr.isatty():
        from tqdm import tqdm

        bar = tqdm(total=args.inputs * len(args.parsers), desc="fuzz", unit="input",
                   leave=False)
    results: list[_Result] = []
    with _quiet_parsers(nets):
        try:
            for offset, name in enumerate(args.parsers):
                mutator = Mutator(args.seed * 1000 + offset, SEEDS[name](data_dir),
                                  targets[name].in_place_share)
                if bar is not None:
                    bar.set_postfix_str(name)
                result = _Result(name)
                _fuzz(targets[name], mutator, args.inputs, result, nets, bar)
                results.append(result)
        finally:
            if bar is not None:
                bar.close()
    _report(results, nets, data_dir, args.seed)
    return 0


@contextlib.contextmanager
def _quiet_parsers(nets: _SafetyNets) -> Iterator[None]:
    """The parsers log each kind of rejection a few times: keep the terminal for the report,
    but send the records that carry a traceback (the safety nets) to ``nets``."""
    saved = []
    for name in LOGGERS:
        logger = logging.getLogger(name)
        saved.append((logger, logger.level, logger.propagate))
        logger.setLevel(logging.ERROR)
        logger.propagate = False
        logger.addHandler(nets)
    try:
        yield
    finally:
        for logger, level, propagate in saved:
            logger.removeHandler(nets)
            logger.setLevel(level)
            logger.propagate = propagate


def _report(results: list[_Result], nets: _SafetyNets, data_dir: Path, seed: int) -> None:
    print(f"mutated real captures from {data_dir} (seed {seed})")
    print(f"{'parser':>12} {'inputs':>8} {'rejected':>9} {'clear':>6} {'internal':>8} "
          f"{'uncaught':>8} {'inputs/s':>9}")
    for r in results:
        rate = r.inputs / r.seconds if r.seconds > 0 else 0.0
        print(f"{r.name:>12} {r.inputs:>8} {r.rejected:>9} {r.clear:>6} {r.internal:>8} "
              f"{r.uncaught:>8} {rate:>9.0f}")
    for r in results:
        for key, count in r.crashes.most_common(SHOWN_CRASHES):
            print(f"\n{r.name}: {count} x {key}\n{r.tracebacks[key]}")
    for text in nets.first:
        print(f"\ninternal error (caught by a safety net):\n{text}")
    internal = sum(r.internal for r in results)
    print(f"internal_errors={internal}")
    print(f"uncaught_exceptions={sum(r.uncaught for r in results)}")
