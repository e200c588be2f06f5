"""A campaign against the same runs one after another (issues 18 and 42).

Runs every (track, seed) first one after another in this process (the reference: what a
campaign replaces), then as a campaign with ``--cpus`` CPUs (``--engine``: the default
campaign's process pool, or a local Ray, whose start, worker imports and stop cost about 4 s
here), both measured in this run on this machine. Prints one line per run (both wall times,
whether the two ``outputs_sha256`` agree), then the wall times and, last, ``speedup=``
(sequential / campaign).
A shared machine's other load shows in both; the ratio is the figure. Beside it, what the
machine gives at that moment: ``machine_parallel=`` is the throughput of ``--cpus`` processes
burning CPU at once over one alone (2.0 on two free cores; less when the cores are hyperthreads
of one or other programs use them), and ``efficiency=`` the speed-up over it. Issue 42's target
is ``efficiency >= 0.9`` on the default 16 runs (small_track and small_oval, seeds 1-8) with
every row's ``outputs_sha256`` equal to its serial run's.
"""

from __future__ import annotations

import argparse
import logging
import tempfile
import time
from pathlib import Path

from common.cli_types import positive_int, seed_list
from orchestrator.config import AppConfig

HELP = "campaign vs the same runs in turn: speed-up, same outputs"
TARGET_EFFICIENCY = 0.9
"""The campaign's speed-up over ``machine_parallel`` measured in the same run (issue 42)."""

SHARED_TRACKS = Path(__file__).resolve().parents[2] / "shared" / "data" / "tracks" / "eufs"
DEFAULT_TRACKS = f"{SHARED_TRACKS / 'small_track.csv'},{SHARED_TRACKS / 'small_oval.csv'}"


def _burn(iterations: int) -> float:
    """Wall time (s) of a pure-Python CPU loop."""
    t0 = time.perf_counter()
    x = 0
    for i in range(iterations):
        x += i * i
    return time.perf_counter() - t0


def machine_parallel(processes: int, iterations: int = 10_000_000) -> float:
    """Throughput of ``processes`` CPU-bound processes at once over one alone (a reference for
    the campaign's speed-up, measured now: at most ``processes``)."""
    from concurrent.futures import ProcessPoolExecutor

    with ProcessPoolExecutor(max_workers=processes) as pool:
        list(pool.map(_burn, [1000] * processes))  # workers started before timing
        alone = min(pool.submit(_burn, iterations).result() for _ in range(2))
        t0 = time.perf_counter()
        list(pool.map(_burn, [iterations] * processes))
        together = time.perf_counter() - t0
    return processes * alone / together


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``bench campaign``."""
    from scale.cli import track_names

    parser.add_argument("--tracks", type=track_names, default=None,
                        help="tracks as 'campaign --tracks' (default: the shared small_track "
                             "and small_oval)")
    parser.add_argument("--seeds", type=seed_list, default=seed_list("1-8"),
                        help="seeds (default 1-8: 16 runs on the two default tracks)")
    parser.add_argument("--laps", type=positive_int, default=1, help="laps per run (default 1)")
    parser.add_argument("--cpus", type=positive_int, default=2,
                        help="processes of the pool, or CPUs of the local Ray (default 2)")
    parser.add_argument("--engine", choices=("pool", "ray"), default="pool",
                        help="what runs the campaign: pool (the default campaign's, processes on "
                             "this machine) or ray (a local Ray)")


def run(args: argparse.Namespace, config: AppConfig) -> int:
    """Sequential runs, then the campaign; the last line is ``speedup=``."""
    from scale.campaign import run_campaign
    from scale.cli import track_names
    from scale.engine import require_ray
    from scale.runs import RunRequest, run_one

    if args.engine == "ray":
        require_ray()
    tracks = args.tracks or track_names(DEFAULT_TRACKS)
    request = RunRequest(tracks=tracks, seeds=args.seeds, laps=args.laps)
    specs = request.specs()
    print(f"{len(specs)} runs: one after another, then a campaign ({args.engine}) on "
          f"{args.cpus} CPUs", flush=True)
    capacity_before = machine_parallel(args.cpus)
    sequential: dict[str, dict] = {}
    t0 = time.perf_counter()
    for spec in specs:
        sequential[spec.run_id] = run_one(config, spec)
    sequential_s = time.perf_counter() - t0
    logging.getLogger().setLevel(logging.WARNING)
    with tempfile.TemporaryDirectory(prefix="bench_campaign_") as tmp:
        t0 = time.perf_counter()
        result = run_campaign(config, request, Path(tmp), num_cpus=args.cpus, progress=False,
                              engine=args.engine)
        campaign_s = time.perf_counter() - t0  # the engine's start and stop included
    same = 0
    for row in sorted(result.rows, key=lambda r: (r["track"], int(r["seed"]))):
        alone = sequential[row["run_id"]]
        agree = bool(row["outputs_sha256"]) and row["outputs_sha256"] == alone["outputs_sha256"]
        same += agree
        print(f"{Path(row['track']).stem:>16}:{row['seed']:<3} alone {alone['wall_s']:7.1f} s  "
              f"in campaign {float(row['wall_s']):7.1f} s  same_outputs={agree}  "
              f"{row['error'] or ''}")
    print(f"sequential_s={sequential_s:.1f} campaign_s={campaign_s:.1f} "
          f"same_outputs={same}/{len(specs)} failed={result.failed}")
    capacity = (capacity_before + machine_parallel(args.cpus)) / 2  # before and after
    speedup = sequential_s / campaign_s
    efficiency = speedup / capacity
    verdict = "met" if efficiency >= TARGET_EFFICIENCY else "not met"
    print(f"machine_parallel={capacity:.2f} efficiency={efficiency:.2f} "
          f"(target >= {TARGET_EFFICIENCY}: {verdict})")
    print(f"speedup={speedup:.2f}")
    return 0 if same == len(specs) else 1
