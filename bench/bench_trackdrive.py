"""Trackdrive in the full closed loop: exploration lap + autonomous laps on generated tracks.

Runs ``sim`` (no rendering, no recording) on ``gen:1`` .. ``gen:N`` (and FSG with ``--fsg``) and
prints per track: laps completed, cones hit, off-track events, pose RMSE, best lap time and its
ratio to the friction-limited minimum lap time along the centreline
(:func:`planner.speed_profile.min_lap_time_s`). Last line:
``worst_lap_ratio=<x> cones_hit=<total>`` (a track that did not complete a lap counts as ratio
``inf``). Each track takes about a minute of wall time for 10 laps; run it alone.
"""

from __future__ import annotations

import argparse
import copy
import math
import tempfile
import time
from pathlib import Path
from typing import Any

from common.cli_types import non_negative_int, positive_int
from orchestrator.config import AppConfig
from simulator.faults import fault_spec

HELP = "closed-loop trackdrive on generated tracks: laps, cones hit, best lap / minimum"

FSG = Path(__file__).resolve().parents[2] / "shared" / "data" / "tracks" / "amz_fssim" / "FSG.yaml"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``bench trackdrive``."""
    parser.add_argument("--tracks", type=positive_int, default=6, help="generated tracks gen:1..N")
    parser.add_argument("--laps", type=positive_int, default=10, help="autonomous laps per track")
    parser.add_argument("--fsg", action="store_true", help="also run FSG (shared data)")
    parser.add_argument("--seed", type=non_negative_int, default=None,
                        help="simulation seed (default: config)")
    parser.add_argument("--fault", type=fault_spec, action="append", default=[],
                        metavar="KIND@T[:DURATION]",
                        help="inject a fault on every track (repeatable)")


def _one(config: AppConfig, track: str, laps: int, seed: int | None,
         faults: list[str]) -> dict[str, Any]:
    from orchestrator.sim import SimOptions, run_sim
    from planner.speed_profile import min_lap_time_s
    from simulator.tracks import load_track

    with tempfile.TemporaryDirectory(prefix="bench_trackdrive_") as tmp:
        summary = run_sim(copy.deepcopy(config), SimOptions(
            track=track, laps=laps, seed=seed, render=False, record=False, out_dir=Path(tmp),
            faults=list(faults)))
    t_min = min_lap_time_s(load_track(track).centreline_xy_m, config.car)
    best = summary.get("best_lap_time_s")
    summary["min_lap_time_s"] = t_min
    summary["lap_ratio"] = best / t_min if best else math.inf
    return summary


def run(args: argparse.Namespace, config: AppConfig) -> int:
    """Run the benchmark; one line per track, then ``worst_lap_ratio=... cones_hit=...``."""
    tracks = [f"gen:{i}" for i in range(1, args.tracks + 1)]
    if args.fsg:
        tracks.append(str(FSG))
    print(f"{'track':>10} {'laps':>5} {'cones':>5} {'off':>4} {'rmse_m':>7} {'best_s':>7} "
          f"{'min_s':>7} {'ratio':>6} {'wall_s':>6}  stop_reason")
    worst = 0.0
    cones = 0
    failed = 0
    for track in tracks:
        wall0 = time.perf_counter()
        s = _one(config, track, args.laps, args.seed, args.fault)
        wall = time.perf_counter() - wall0
        name = "FSG" if track == str(FSG) else track
        best = s.get("best_lap_time_s")
        rmse = s.get("pose_rmse_m")
        print(f"{name:>10} {s['laps_completed']:>5d} {s['cones_hit']:>5d} {s['off_track']:>4d} "
              f"{rmse if rmse is not None else math.nan:>7.3f} "
              f"{best if best else math.nan:>7.2f} {s['min_lap_time_s']:>7.2f} "
              f"{s['lap_ratio']:>6.3f} {wall:>6.1f}  {s['stop_reason']}", flush=True)
        worst = max(worst, s["lap_ratio"])
        cones += int(s["cones_hit"])
        if s["laps_completed"] < args.laps or s["off_track"]:
            failed += 1
    print(f"tracks={len(tracks)} short_or_off_track={failed}")
    print(f"worst_lap_ratio={worst:.3f} cones_hit={cones}")
    return 0
