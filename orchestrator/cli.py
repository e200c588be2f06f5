"""Subcommands of Tier 1: ``sim``, ``replay``, ``record``, ``drive`` and ``emulate``."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from common.config import AppConfig


def register(subparsers: Any, common: argparse.ArgumentParser) -> None:
    """Add Main's subcommands."""
    sim = subparsers.add_parser(
        "sim", parents=[common],
        help="closed-loop simulation: exploration lap, loop closure, autonomous laps (default)",
    )
    sim.add_argument("--track", help="'default', 'gen:SEED', or a track file (.csv EUFS, .yaml "
                     "FSSIM)")
    sim.add_argument("--laps", type=int, help="autonomous laps (default: config sim.laps)")
    sim.add_argument("--seed", type=int, help="random seed of the simulated world")
    sim.add_argument("--mapper", choices=("slam", "smoother"), help="mapping backend")
    sim.add_argument("--out", type=Path, help="run folder (default: runs/<date-time>/)")
    render = sim.add_mutually_exclusive_group()
    render.add_argument("--render", dest="render", action="store_true", default=None,
                        help="render PNG frames and a movie of the run")
    render.add_argument("--no-render", dest="render", action="store_false",
                        help="do not render frames")
    sim.add_argument("--no-record", dest="record", action="store_false", default=None,
                     help="do not write recording.mcap")
    sim.add_argument("--realtime", action="store_true",
                     help="pace the simulation to the wall clock")
    sim.add_argument("--fault", action="append", default=[], metavar="KIND@T[:DURATION]",
                     help="inject a fault: estop, gps-dropout, lidar-dead, imu-nan, can-garbage "
                     "(repeatable)")
    sim.add_argument("--json", action="store_true", help="print the summary as JSON")
    sim.set_defaults(func=_sim)


def _sim(args: argparse.Namespace, config: AppConfig) -> int:
    from orchestrator.sim import SimOptions, run_sim
    from orchestrator.summary_table import format_summary

    options = SimOptions(
        track=args.track, laps=args.laps, seed=args.seed, mapper=args.mapper, out_dir=args.out,
        render=args.render, record=args.record, realtime=args.realtime, faults=args.fault,
        progress=sys.stderr.isatty(),
    )
    summary = run_sim(config, options)
    if args.json:
        import json

        print(json.dumps(summary, indent=2))
    else:
        print(format_summary(summary))
    return 0 if summary["stop_reason"] != "timeout" else 1
