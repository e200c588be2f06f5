"""Subcommands ``campaign`` and ``tune``: many closed-loop runs on Ray (:mod:`scale.engine`).

Ray and Optuna are imported only when a command runs, so ``--help`` works without them and a
missing one is a one-line error naming the extra to install.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from common.cli_types import positive_int, seed_list
from orchestrator.config import AppConfig
from simulator.faults import fault_spec


def fault_variants(text: str) -> list[tuple[str, ...]]:
    """``--faults``: comma-separated variants, each ``none`` or faults joined by ``+``
    (``estop@30,gps-dropout@10:5+lidar-dead@40``): one run per variant."""
    variants: list[tuple[str, ...]] = []
    for part in (p.strip() for p in text.split(",")):
        if not part:
            continue
        if part == "none":
            variants.append(())
            continue
        variants.append(tuple(fault_spec(f.strip()) for f in part.split("+") if f.strip()))
    if not variants:
        raise argparse.ArgumentTypeError(f"no fault in {text!r}")
    return variants


def track_names(text: str) -> list[str]:
    """``--tracks``: as ``bench trackdrive`` takes them; files become absolute paths (the
    workers may run in another folder)."""
    from bench.bench_trackdrive import track_list

    return [str(Path(t).resolve()) if Path(t).exists() else t for t in track_list(text)]


def _engine_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--address", default=None, metavar="ray://HOST:PORT|HOST:PORT",
                        help="a Ray cluster to run on (default: a local Ray on this machine)")
    parser.add_argument("--cpus", type=positive_int, default=None,
                        help="CPUs of the local Ray (default: all of this machine's)")
    parser.add_argument("--no-progress", dest="progress", action="store_false",
                        help="no progress bar")


def _run_arguments(parser: argparse.ArgumentParser, seeds_default: str | None) -> None:
    parser.add_argument("--tracks", type=track_names, required=True,
                        help="N (gen:1..N) or a comma list of names (default, gen:N, hard:NAME), "
                             "files and folders")
    parser.add_argument("--seeds", type=seed_list, required=seeds_default is None,
                        default=seed_list(seeds_default) if seeds_default else None,
                        help="simulation seeds, e.g. 1-100 or 1,5")
    parser.add_argument("--laps", type=positive_int, default=None,
                        help="autonomous laps per run (default: config mission.laps)")
    parser.add_argument("--mission", choices=("trackdrive", "autocross"), default=None,
                        help="mission (default: the config's)")


def register(subparsers: Any, common: argparse.ArgumentParser) -> None:
    """Add ``campaign`` and ``tune``."""
    campaign = subparsers.add_parser(
        "campaign", parents=[common],
        help="closed-loop runs over tracks x seeds x faults x settings on Ray, with a report")
    _run_arguments(campaign, None)
    campaign.add_argument("--faults", type=fault_variants, default=[()],
                          metavar="KIND@T[:D],...",
                          help="fault variants, one run each: comma-separated, 'none' for no "
                               "fault, '+' joins faults of one run (default: none)")
    campaign.add_argument("--set", dest="settings", nargs="+", action="append", default=None,
                          metavar="KEY=VALUE",
                          help="a setting to run (config keys, e.g. planner.max_speed_mps=12); "
                               "repeat --set for more settings (default: the config as is)")
    campaign.add_argument("--out", type=Path, required=True,
                          help="campaign folder (results.csv, campaign.json, report.html); "
                               "an existing one is resumed")
    _engine_arguments(campaign)
    campaign.set_defaults(func=_campaign)

    from scale.tune_cli import register_tune

    register_tune(subparsers, common, _run_arguments, _engine_arguments)


def _campaign(args: argparse.Namespace, config: AppConfig) -> int:
    from scale.campaign import run_campaign
    from scale.engine import require_ray
    from scale.runs import RunRequest, configured, parse_setting
    from simulator.tracks import load_track

    require_ray()
    for track in args.tracks:  # a wrong track is a one-line error before anything starts
        load_track(track)
    settings: list[tuple[tuple[str, Any], ...]] = (
        [parse_setting(pairs) for pairs in args.settings] if args.settings else [()])
    for setting in settings:
        configured(config, setting)
    request = RunRequest(tracks=args.tracks, seeds=args.seeds,
                         laps=args.laps or config.mission.laps, mission=args.mission,
                         faults=args.faults, settings=settings)
    result = run_campaign(config, request, args.out, address=args.address, num_cpus=args.cpus,
                          progress=args.progress and sys.stderr.isatty(),
                          argv=sys.argv[1:])
    ok = [r for r in result.rows if not r["error"]]
    print(f"runs={len(result.rows)} ran={result.ran} resumed={result.skipped} "
          f"failed={sum(1 for r in result.rows if r['error'])} "
          f"cones_hit={sum(int(float(r['cones_hit'] or 0)) for r in ok)} "
          f"engine=ray-{result.engine.version}@{result.engine.address} "
          f"nodes={result.engine.nodes} cpus={result.engine.cpus:g}")
    print(f"results: {args.out / 'results.csv'}  report: {args.out / 'report.html'}")
    print(f"wall_s={result.wall_s:.1f}")
    return 0 if not result.failed else 1
