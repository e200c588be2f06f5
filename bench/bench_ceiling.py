"""What the track in view allows an unseen lap: the explored lap's ceiling (issue 45).

While exploring, the car must be able to stop within the track it has seen
(:mod:`planner.exploration_speed`): after the late cover (``planner.exploration_late_cover_s``)
the safety supervisor's controlled stop (``controller.safety``: its reaction, margin and
deceleration) must fit in the seen track ahead. With ``VIEW`` metres of track in view that caps
the speed everywhere at the speed whose room is ``VIEW``. This benchmark times a point mass
with the car's full limits (no safety factor, as :func:`planner.speed_profile.min_lap_time_s`)
and that cap on a flying lap of each track's centreline, and prints its ratio to the
friction-limited minimum: the best explored-lap ratio ``bench trackdrive --mission autocross``
could show with that much in view, whatever the planner does. It is optimistic (no standing
start, the full lateral limit, the view never shorter in a bend): how far a measured explored
lap is above it is the planner's (and the standing start's), how far it is above 1 the view's.

No simulation runs: a second a track. Last line: the median and worst ceiling ratio for the
first ``--view-m``.
"""

from __future__ import annotations

import argparse
import statistics

from common.cli_types import positive_float
from orchestrator.config import AppConfig

HELP = "explored lap's ceiling: stopping within the track in view"


def view_list(text: str) -> list[float]:
    """Comma-separated lengths (m) of track in view, each > 0."""
    views = [positive_float(part) for part in text.split(",") if part.strip()]
    if not views:
        raise argparse.ArgumentTypeError(f"no length in {text!r}")
    return views


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``bench ceiling``."""
    from bench.bench_trackdrive import add_track_arguments

    add_track_arguments(parser, 20)
    parser.add_argument("--view-m", type=view_list, default=view_list("14,17,20"),
                        help="lengths (m) of track in view ahead of the car, comma-separated "
                             "(default 14,17,20: the LiDAR's landmarks alone, the camera's "
                             "tentative cones as simulated, the camera's range)")


def speed_in_view_mps(view_m: float, config: AppConfig) -> float:
    """The highest speed (m/s) that leaves room to stop within ``view_m`` (m) of seen track:
    the late cover, then the supervisor's controlled stop (the planner's own table,
    :func:`planner.speed_profile.late_cover_table`, and
    :func:`planner.exploration_speed.view_speed_mps`)."""
    from controller.safety import late_stop_distance_m
    from planner.exploration_speed import view_speed_mps
    from planner.speed_profile import late_cover_table

    safety = config.controller.safety
    room, speed = late_cover_table(lambda v: late_stop_distance_m(v, safety),
                                   config.planner.exploration_late_cover_s)
    return view_speed_mps(view_m, room, speed)


def run(args: argparse.Namespace, config: AppConfig) -> int:
    """One line per track (its minimum lap and the ceiling's ratio at each view), then the
    median and worst ratio at the first view."""
    from bench.bench_trackdrive import FSG, track_name
    from planner.speed_profile import min_lap_time_s
    from simulator.tracks import load_track

    tracks = list(args.tracks) + ([str(FSG)] if args.fsg else [])
    caps = [speed_in_view_mps(view, config) for view in args.view_m]
    for view, cap in zip(args.view_m, caps, strict=True):
        print(f"{view:.1f} m in view: at most {cap:.2f} m/s")
    print(f"{'track':>26} {'min_s':>7} " + " ".join(f"{f'{v:g} m':>8}" for v in args.view_m))
    ratios: list[list[float]] = [[] for _ in args.view_m]
    for track in tracks:
        centre = load_track(track).centreline_xy_m
        t_min = min_lap_time_s(centre, config.car)
        row = []
        for i, cap in enumerate(caps):
            ratio = min_lap_time_s(centre, config.car, max_speed_mps=cap) / t_min
            ratios[i].append(ratio)
            row.append(f"{ratio:>8.3f}")
        print(f"{track_name(track):>26} {t_min:>7.2f} " + " ".join(row), flush=True)
    first = ratios[0]
    print(f"view_m={args.view_m[0]:g} median_ceiling_ratio={statistics.median(first):.3f} "
          f"worst_ceiling_ratio={max(first):.3f}")
    return 0
