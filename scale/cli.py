"""Subcommands ``campaign`` and ``tune``: many closed-loop runs on a process pool or Ray
(:mod:`scale.runners`).

Ray and Optuna are imported only when a command runs, so ``--help`` works without them and a
missing one is a one-line error naming the extra to install.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from common.cli_types import non_negative_int, positive_int, seed_list
from orchestrator.config import MISSIONS, AppConfig
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
    from scale.runners import ENGINES

    parser.add_argument("--engine", choices=ENGINES, default="auto",
                        help="what runs the runs: pool (processes on this machine), ray (a local "
                             "Ray, or the cluster at --address); auto (default): ray with "
                             "--address, pool without")
    parser.add_argument("--address", default=None, metavar="ray://HOST:PORT|HOST:PORT",
                        help="a Ray cluster to run on (default: this machine)")
    parser.add_argument("--cpus", type=positive_int, default=None,
                        help="processes (pool) or CPUs of the local Ray (default: all of this "
                             "machine's)")
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
    parser.add_argument("--mission", choices=MISSIONS, default=None,
                        help="mission (default: the config's)")


def register(subparsers: Any, common: argparse.ArgumentParser) -> None:
    """Add ``campaign`` and ``tune``."""
    campaign = subparsers.add_parser(
        "campaign", parents=[common],
        help="closed-loop runs over tracks x seeds x faults x settings (processes here, or Ray), "
             "with a report")
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

    _register_tune(subparsers, common)


def _campaign(args: argparse.Namespace, config: AppConfig) -> int:
    from scale.campaign import run_campaign
    from scale.engine import require_ray
    from scale.runners import resolve_engine
    from scale.runs import RunRequest, configured, parse_setting
    from simulator.tracks import load_track

    if resolve_engine(args.engine, args.address) == "ray":
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
                          argv=sys.argv[1:], engine=args.engine)
    ok = [r for r in result.rows if not r["error"]]
    print(f"runs={len(result.rows)} ran={result.ran} resumed={result.skipped} "
          f"failed={sum(1 for r in result.rows if r['error'])} "
          f"cones_hit={sum(int(float(r['cones_hit'] or 0)) for r in ok)} "
          f"engine={result.engine.engine}-{result.engine.version}@{result.engine.address} "
          f"nodes={result.engine.nodes} cpus={result.engine.cpus:g}")
    print(f"results: {args.out / 'results.csv'}  report: {args.out / 'report.html'}")
    print(f"wall_s={result.wall_s:.1f}")
    return 0 if not result.failed else 1


def _register_tune(subparsers: Any, common: argparse.ArgumentParser) -> None:
    tune = subparsers.add_parser(
        "tune", parents=[common],
        help="search planner/controller/filter parameters (Optuna) with runs in parallel; writes "
             "the best setting as a --config TOML")
    tune.add_argument("--space", type=Path, required=True,
                      help="TOML search space (see scale/tune_space.toml)")
    tune.add_argument("--trials", type=positive_int, default=20,
                      help="trials, the configuration as it is (trial 0) included (default 20)")
    _run_arguments(tune, "1")
    tune.add_argument("--sampler-seed", type=non_negative_int, default=0,
                      help="seed of Optuna's TPE sampler (default 0)")
    tune.add_argument("--batch", type=positive_int, default=None,
                      help="trials run at once (default: enough to fill the CPUs)")
    tune.add_argument("--out", type=Path, required=True,
                      help="folder for trials.csv, tune.json and best.toml")
    _engine_arguments(tune)
    tune.set_defaults(func=_tune)


def _tune(args: argparse.Namespace, config: AppConfig) -> int:
    from scale.engine import require_optuna, require_ray
    from scale.runners import resolve_engine
    from scale.tune import load_space, tune
    from simulator.tracks import load_track

    if resolve_engine(args.engine, args.address) == "ray":
        require_ray()
    require_optuna()
    params = load_space(args.space, config)
    for track in args.tracks:
        load_track(track)
    summary = tune(config, params, args.tracks, args.seeds, args.laps or config.mission.laps,
                   args.trials, args.out, mission=args.mission, address=args.address,
                   num_cpus=args.cpus, sampler_seed=args.sampler_seed, batch=args.batch,
                   base_config=Path(args.config) if args.config else None, engine=args.engine)
    base, best = summary["baseline"], summary["best"]
    print(f"baseline (trial 0): mean best lap {base['mean_best_lap_s']:.3f} s, "
          f"cones hit {base['cones_hit']}, feasible {base['feasible']}")
    if best is None:
        print("no feasible trial (every one hit cones, left the track or failed)",
              file=sys.stderr)
        return 1
    print(f"best (trial {best['trial']}): mean best lap {best['mean_best_lap_s']:.3f} s, "
          f"cones hit {best['cones_hit']}: {best['params']}")
    print(f"best setting: {summary['best_toml']} (use with --config)")
    print(f"improvement_s={summary['improvement_s']:.3f}")
    return 0
