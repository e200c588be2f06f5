"""Trackdrive in the full closed loop: exploration lap + autonomous laps, over many layouts.

Runs ``sim`` (no rendering, no recording) on every (track, seed) and prints one line each: laps
completed, cones hit, off-track events, pose RMSE, best lap time and its ratio to the
friction-limited minimum lap time along the centreline
(:func:`planner.speed_profile.min_lap_time_s`), and the explored lap's (the first, driven from
the cones as they are mapped; autocross's one lap) over the same minimum, the seen track
ahead of the car while it explored (its median, ``view_m``) and the ceiling that much in view
sets (``ceiling``: :mod:`bench.bench_ceiling`'s ratio at that view), and the least gap between
the car's outline and a cone's base over the run (``clear_m``, :mod:`simulator.clearance`:
clean by how much; negative, a cone touched). ``standing``: the explored lap over the
friction-limited minimum of the same lap from a standstill
(:func:`planner.speed_profile.min_standing_lap_time_s`): the explored lap is timed from the go,
and a flying lap's minimum leaves out a launch no car avoids (3-15 % of a lap on the layouts
here). Tracks:
``--tracks N`` (gen:1..N), or a list of
names, files and folders (every ``.csv``/``.yaml`` in a folder), ``--hard`` adds the hard
layouts (:mod:`simulator.hard_tracks`), ``--fsg`` FSG from the shared data. A run is clean when
it completes its laps with no cone hit and no off-track event. Last lines: the clean count, the
median and worst explored ratio (and over the standing-start minimum), the median ceiling
and the least clearance of any run; the
median and worst lap ratio, and the worst track by name (a run that did not complete a lap
counts as ratio ``inf``). ``--jobs`` runs that many simulations side by side.
"""

from __future__ import annotations

import argparse
import copy
import math
import re
import statistics
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path
from typing import Any

from common.cli_types import positive_int, seed_list
from orchestrator.config import AppConfig
from orchestrator.progress import Progress
from simulator.faults import fault_spec

HELP = "closed-loop trackdrive over many layouts: clean runs, cones hit, best lap / minimum"

FSG = Path(__file__).resolve().parents[2] / "shared" / "data" / "tracks" / "amz_fssim" / "FSG.yaml"


def track_list(text: str) -> list[str]:
    """``N`` (gen:1..N) or comma-separated names, files, folders (their .csv/.yaml files) and
    ranges of generated tracks (``gen:1..30``)."""
    text = text.strip()
    if text.isdigit():
        count = int(text)
        if count < 1:
            raise argparse.ArgumentTypeError("must be >= 1 generated tracks or a track list")
        return [f"gen:{i}" for i in range(1, count + 1)]
    tracks: list[str] = []
    for part in (p.strip() for p in text.split(",")):
        if not part:
            continue
        path = Path(part)
        span = re.fullmatch(r"gen:(\d+)\.\.(\d+)", part)
        if span:
            first, last = int(span.group(1)), int(span.group(2))
            if not 1 <= first <= last:
                raise argparse.ArgumentTypeError(f"empty or bad range {part!r}")
            tracks.extend(f"gen:{i}" for i in range(first, last + 1))
        elif path.is_dir():
            found = sorted(str(f) for f in path.iterdir() if f.suffix in (".csv", ".yaml"))
            if not found:
                raise argparse.ArgumentTypeError(f"no .csv or .yaml track in {part!r}")
            tracks.extend(found)
        else:
            tracks.append(part)
    if not tracks:
        raise argparse.ArgumentTypeError(f"no track in {text!r}")
    return tracks


def add_track_arguments(parser: argparse.ArgumentParser, default_count: int) -> None:
    """``--tracks`` (:func:`track_list`, default gen:1..``default_count``) and ``--fsg``."""
    parser.add_argument("--tracks", type=track_list, default=track_list(str(default_count)),
                        help=f"N (gen:1..N, default {default_count}) or a comma list of names, "
                             "files, folders, gen:A..B ranges")
    parser.add_argument("--fsg", action="store_true", help="also FSG (shared data)")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``bench trackdrive``."""
    add_track_arguments(parser, 6)
    parser.add_argument("--hard", action="store_true",
                        help="also the hard layouts (hard:hairpins, ...)")
    parser.add_argument("--laps", type=positive_int, default=10, help="autonomous laps per run")
    parser.add_argument("--seeds", type=seed_list, default=None,
                        help="simulation seeds, e.g. 1-3 or 1,5 (default: the config's)")
    parser.add_argument("--jobs", type=positive_int, default=1,
                        help="simulations side by side (default 1; the machine's cores at most)")
    parser.add_argument("--mission", choices=("trackdrive", "autocross"), default=None,
                        help="mission (default: the config's)")
    parser.add_argument("--exploration", choices=("autonomous", "manual"), default=None,
                        help="who drives trackdrive's first lap (default: the config's)")
    parser.add_argument("--fault", type=fault_spec, action="append", default=[],
                        metavar="KIND@T[:DURATION]",
                        help="inject a fault on every track (repeatable)")


def _one(config: AppConfig, track: str, laps: int, seed: int | None,
         faults: list[str], mission: str | None = None,
         exploration: str | None = None) -> dict[str, Any]:
    import logging

    from orchestrator.sim import SimOptions, run_sim
    from planner.speed_profile import min_lap_time_s, min_standing_lap_time_s
    from simulator.tracks import load_track

    logging.getLogger().setLevel(logging.ERROR)  # the table is the output; warnings are many
    logging.getLogger("progress").setLevel(logging.WARNING)
    wall0 = time.perf_counter()
    try:
        with tempfile.TemporaryDirectory(prefix="bench_trackdrive_") as tmp:
            summary = run_sim(copy.deepcopy(config), SimOptions(
                track=track, laps=laps, seed=seed, render=False, record=False,
                out_dir=Path(tmp), faults=list(faults), mission=mission,
                exploration=exploration))
        centreline = load_track(track).centreline_xy_m
        t_min = min_lap_time_s(centreline, config.car)
        t_standing = min_standing_lap_time_s(centreline, config.car)
    except Exception as exc:  # a run that fails is a row, not the end of the benchmark
        return {"track": track, "seed": seed, "error": f"{type(exc).__name__}: {exc}",
                "wall_s": time.perf_counter() - wall0}
    best = summary.get("best_lap_time_s")
    explored = summary.get("exploration_lap_time_s")
    summary.update(track=track, seed=seed, min_lap_time_s=t_min,
                   lap_ratio=best / t_min if best else math.inf,
                   explored_ratio=explored / t_min if explored else math.inf,
                   explored_standing_ratio=explored / t_standing if explored else math.inf,
                   wall_s=time.perf_counter() - wall0)
    return summary


def track_name(track: str) -> str:
    """The short name of a track in a table: FSG, a file's stem, or the name as given."""
    return "FSG" if track == str(FSG) else Path(track).stem if "/" in track else track


def _least_gap_m(s: dict[str, Any]) -> float:
    """The run's least gap (m) between the car's outline and a cone's base
    (:mod:`simulator.clearance`); inf when none came near, NaN when not measured."""
    least = s.get("least_clearance")
    if not isinstance(least, dict):
        return math.nan
    gap = least.get("gap_m")
    return math.inf if gap is None else float(gap)


def _row(s: dict[str, Any], laps: int) -> tuple[str, bool]:
    """The table line of one run and whether it was clean."""
    name = f"{track_name(s['track'])}:{s['seed'] if s['seed'] is not None else '-'}"
    if "error" in s:
        return f"{name:>26} {'error':>5}  {s['error']}", False
    clean = s["laps_completed"] >= laps and not s["cones_hit"] and not s["off_track"]
    best = s.get("best_lap_time_s")
    rmse = s.get("pose_rmse_m")
    view = s.get("mission_result") or {}
    mapped = s.get("map") or {}
    map_ratio = (mapped["landmarks"] / mapped["true_cones"]
                 if mapped.get("true_cones") and "landmarks" in mapped else math.nan)
    gap = _least_gap_m(s)
    return (f"{name:>26} {s['laps_completed']:>5d} {s['cones_hit']:>5d} {s['off_track']:>4d} "
            f"{rmse if rmse is not None else math.nan:>7.3f} "
            f"{best if best else math.nan:>7.2f} {s['min_lap_time_s']:>7.2f} "
            f"{s['lap_ratio']:>6.3f} {s['explored_ratio']:>8.3f} "
            f"{s.get('explored_standing_ratio', math.nan):>8.3f} "
            f"{view.get('explored_view_m') or math.nan:>6.1f} "
            f"{view.get('view_ceiling_ratio') or math.nan:>7.3f} {map_ratio:>5.2f} "
            f"{gap:>7.3f} {s['wall_s']:>6.1f} "
            f"{'clean' if clean else 'FAIL':>5}  "
            f"{s['stop_reason']}"), clean


def run(args: argparse.Namespace, config: AppConfig) -> int:
    """Run the benchmark; one line per run, then the clean count, the lap ratios and the worst
    track."""
    tracks = list(args.tracks)
    if args.hard:
        from simulator.hard_tracks import HARD_LAYOUTS

        tracks += [f"hard:{name}" for name in HARD_LAYOUTS]
    if args.fsg:
        tracks.append(str(FSG))
    seeds: list[int | None] = list(args.seeds) if args.seeds else [None]
    runs = [(track, seed) for track in tracks for seed in seeds]
    print(f"{'track:seed':>26} {'laps':>5} {'cones':>5} {'off':>4} {'rmse_m':>7} {'best_s':>7} "
          f"{'min_s':>7} {'ratio':>6} {'explored':>8} {'standing':>8} {'view_m':>6} "
          f"{'ceiling':>7} "
          f"{'map_x':>5} {'clear_m':>7} {'wall_s':>6} {'':>5}  stop_reason",
          flush=True)
    results: list[dict[str, Any]] = []
    clean_runs = 0
    progress = Progress("trackdrive", len(runs), "runs", sys.stderr.isatty())
    with ProcessPoolExecutor(max_workers=args.jobs) as pool:
        futures = [pool.submit(_one, config, track, args.laps, seed, args.fault, args.mission,
                               args.exploration) for track, seed in runs]
        for future in as_completed(futures):
            s = future.result()
            results.append(s)
            line, clean = _row(s, args.laps)
            clean_runs += clean
            progress.write(line)
            progress.update(len(results), f"clean {clean_runs}")
    progress.close()
    ratios = [float(s.get("lap_ratio", math.inf)) for s in results]
    finite = [r for r in ratios if math.isfinite(r)]
    worst = max(results, key=lambda s: (float(s.get("lap_ratio", math.inf)),
                                        int(s.get("cones_hit", 0))))
    cones = sum(int(s.get("cones_hit", 0)) for s in results)
    explored = [float(s.get("explored_ratio", math.inf)) for s in results]
    finite_explored = [r for r in explored if math.isfinite(r)]
    median_explored = statistics.median(finite_explored) if finite_explored else math.inf
    standing = [float(s.get("explored_standing_ratio", math.inf)) for s in results]
    finite_standing = [r for r in standing if math.isfinite(r)]
    ceilings = [float(s["mission_result"]["view_ceiling_ratio"]) for s in results
                if (s.get("mission_result") or {}).get("view_ceiling_ratio") is not None]
    median_ceiling = statistics.median(ceilings) if ceilings else math.nan
    gaps = [g for g in map(_least_gap_m, results) if not math.isnan(g)]
    print(f"runs={len(results)} clean={clean_runs} cones_hit={cones} "
          f"median_explored_ratio={median_explored:.3f} worst_explored_ratio={max(explored):.3f} "
          f"median_view_ceiling_ratio={median_ceiling:.3f} "
          f"median_explored_standing_ratio="
          f"{statistics.median(finite_standing) if finite_standing else math.inf:.3f} "
          f"worst_explored_standing_ratio={max(standing):.3f} "
          f"least_clearance_m={min(gaps) if gaps else math.nan:.3f}")
    print(f"median_lap_ratio={statistics.median(finite) if finite else math.inf:.3f} "
          f"worst_lap_ratio={max(ratios):.3f} worst_track={track_name(worst['track'])}"
          f":{worst['seed'] if worst['seed'] is not None else '-'}")
    return 0
