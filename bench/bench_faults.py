"""Faults at speed: every ``--fault`` kind injected while the car races, on several tracks.

For each track a run with no fault finds the first moment of the autonomous laps at which the
car is at ``--speed`` (default 12 m/s) or more; every fault kind is then injected at that moment
(for ``--duration`` seconds, the e-stop for good) in a run of its own. A cell is ``safe`` when no
cone is hit, the car never leaves the track, and the run either finishes its laps (a fault it can
ride out) or ends in a controlled or emergency stop; for the e-stop the stop distance must also
be within v^2 / 20 + 0.1 v metres (v the speed at the e-stop). Prints the matrix, then
``unsafe_cells=<n> cones_hit=<total>``.
"""

from __future__ import annotations

import argparse
import copy
import math
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

from common.cli_types import non_negative_int, positive_float, positive_int
from orchestrator.config import AppConfig
from orchestrator.progress import Progress
from simulator.faults import KINDS

HELP = "faults at speed: each fault kind while racing, per track: outcome, stop distance, hits"

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data" / "tracks"
DEFAULT_TRACKS = f"{SHARED / 'eufs' / 'small_track.csv'},{SHARED / 'amz_fssim' / 'FSG.yaml'},gen:3"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``bench faults``."""
    parser.add_argument("--tracks", default=DEFAULT_TRACKS,
                        help="comma list of tracks (default: small_track, FSG, gen:3)")
    parser.add_argument("--kinds", default=",".join(KINDS),
                        help=f"comma list of fault kinds (default: all: {', '.join(KINDS)})")
    parser.add_argument("--speed", type=positive_float, default=12.0,
                        help="inject when the car is at least this fast (m/s, default 12)")
    parser.add_argument("--duration", type=positive_float, default=3.0,
                        help="how long a fault lasts (s; the e-stop lasts); default 3")
    parser.add_argument("--laps", type=positive_int, default=2, help="autonomous laps per run")
    parser.add_argument("--seed", type=non_negative_int, default=1,
                        help="simulation seed (default 1)")
    parser.add_argument("--jobs", type=positive_int, default=1, help="runs side by side")


def _run(config: AppConfig, track: str, laps: int, seed: int, faults: list[str],
         keep_log: bool) -> dict[str, Any]:
    import logging

    from orchestrator.sim import SimOptions, run_sim

    logging.getLogger().setLevel(logging.ERROR)
    logging.getLogger("progress").setLevel(logging.WARNING)
    wall0 = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="bench_faults_") as tmp:
        summary = run_sim(copy.deepcopy(config), SimOptions(
            track=track, laps=laps, seed=seed, render=False, record=False, out_dir=Path(tmp),
            faults=faults))
        if keep_log:
            log = np.load(Path(tmp) / "run_log.npz")
            summary["_t_s"] = log["t_s"].tolist()
            summary["_speed_mps"] = log["truth"][:, 3].tolist()
    summary["wall_s"] = time.perf_counter() - wall0
    return summary


def _fast_moment_s(summary: dict[str, Any], speed_mps: float) -> float | None:
    """The first time (s) after the handover at which the car is at ``speed_mps`` or more."""
    handover = summary.get("handover_time_s")
    t = np.asarray(summary["_t_s"])
    v = np.asarray(summary["_speed_mps"])
    after = t > (handover if handover is not None else 0.0)
    fast = np.flatnonzero(after & (v >= speed_mps))
    return float(t[fast[0]]) if len(fast) else None


def _verdict(kind: str, s: dict[str, Any], laps: int) -> tuple[bool, str]:
    hits, off = int(s["cones_hit"]), int(s["off_track"])
    reason = str(s["stop_reason"])
    finished = s["laps_completed"] >= laps and reason.startswith("finished")
    stopped = reason not in ("timeout",) and not finished
    safe = hits == 0 and off == 0 and (finished or stopped)
    if kind == "estop":
        estop = s.get("estop") or {}
        dist, allowed = estop.get("stop_distance_m"), estop.get("allowed_distance_m")
        safe = safe and dist is not None and allowed is not None and dist <= allowed
    return safe, "rode it out" if finished else "stopped"


def run(args: argparse.Namespace, config: AppConfig) -> int:
    """Run the matrix; one line per (track, fault), then ``unsafe_cells=... cones_hit=...``."""
    tracks = [t.strip() for t in args.tracks.split(",") if t.strip()]
    kinds = [k.strip() for k in args.kinds.split(",") if k.strip()]
    unknown = sorted(set(kinds) - set(KINDS))
    if unknown:
        raise SystemExit(f"bench faults: unknown fault kinds {unknown} (known: {', '.join(KINDS)})")
    print(f"{'track':>14} {'fault':>12} {'at_s':>6} {'v_mps':>6} {'outcome':>11} {'hits':>4} "
          f"{'off':>3} {'stop_m':>7} {'limit_m':>7} {'safe':>5}  stop_reason", flush=True)
    unsafe = 0
    cones = 0
    with ProcessPoolExecutor(max_workers=args.jobs) as pool:
        baselines = {t: pool.submit(_run, config, t, args.laps, args.seed, [], True)
                     for t in tracks}
        jobs = []
        for track in tracks:
            base = baselines[track].result()
            name = Path(track).stem if "/" in track else track
            at = _fast_moment_s(base, args.speed)
            if at is None:
                print(f"{name:>14} {'-':>12}  never at {args.speed:.1f} m/s "
                      f"(top {max(base['_speed_mps']):.1f} m/s): no cell", flush=True)
                continue
            v_at = float(np.interp(at, base["_t_s"], base["_speed_mps"]))
            for kind in kinds:
                spec = f"{kind}@{at:.2f}" + ("" if kind == "estop" else f":{args.duration:g}")
                jobs.append((name, kind, at, v_at,
                             pool.submit(_run, config, track, args.laps, args.seed, [spec],
                                         False)))
        progress = Progress("faults", len(jobs), "cells", sys.stderr.isatty())
        for done, (name, kind, at, v_at, future) in enumerate(jobs, start=1):
            s = future.result()
            safe, outcome = _verdict(kind, s, args.laps)
            estop = s.get("estop") or {}
            stop_m = estop.get("stop_distance_m", math.nan) if kind == "estop" else math.nan
            limit_m = estop.get("allowed_distance_m", math.nan) if kind == "estop" else math.nan
            unsafe += not safe
            cones += int(s["cones_hit"])
            progress.write(f"{name:>14} {kind:>12} {at:>6.2f} {v_at:>6.2f} {outcome:>11} "
                           f"{s['cones_hit']:>4d} {s['off_track']:>3d} {stop_m:>7.2f} "
                           f"{limit_m:>7.2f} {'yes' if safe else 'NO':>5}  {s['stop_reason']}")
            progress.update(done, f"unsafe {unsafe}")
        progress.close()
    print(f"unsafe_cells={unsafe} cones_hit={cones}")
    return 0
