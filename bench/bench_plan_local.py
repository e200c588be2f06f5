"""The local (exploration) planner: time per call and whether its path stays on the track.

Cone views of one autonomous exploration lap, built from the track's true cones (no simulation
run, so every view is the same on every machine): the car steps along the centreline every
``--step-m`` metres, heading along it; a cone is mapped once it has been within ``--range-m``
and inside ``--fov-deg`` of the heading at one of the poses so far (the camera's range and
field of view by default), with ``--noise-m`` of position noise drawn once per cone (seeded).
So every view holds the cones mapped so far, as the EKF SLAM map grows during the lap.

Over the views, with the cones' true colours and with every colour removed (``UNKNOWN``: camera
dead or not voted), it times:

- ``exploration_path``: the gate marching alone (:func:`planner.exploration_path.exploration_path`);
- ``local``: the local planner's call, :meth:`planner.path_planner.PathPlanner.explore` (cone
  ordering and the loop check, the gates' path, its spline baseframe and speed profile): the
  figure the target (<= 10 ms median on one core) applies to;
- ``plan``: the full :meth:`~planner.path_planner.PathPlanner.plan` on the same views (local
  frame, manoeuvres, speed), the reference measured in the same run: ``local / plan`` is the
  local planner's share of a planning call.

and counts the calls whose path (the baseframe the local call built, from the car on) has every
point inside the true boundaries (``inside``), out of the calls that made a path. Once the
mapped cones close the loop (a lap is mapped) exploring is over: the pass ends there. The
process is pinned to one CPU where the system allows it. Last line:
``plan_local_median_ms=...``.
"""

from __future__ import annotations

import argparse
import copy
import logging
import math
import os
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from common.cli_types import (
    non_negative_float,
    non_negative_int,
    positive_float,
    positive_int,
)
from common.messages import ConeColour, ConeMap, MapState, PoseEstimate
from orchestrator.config import AppConfig
from planner.exploration_path import ENTRY_BEHIND_M, exploration_path
from planner.path_planner import PathPlanner
from simulator.track import Track

log = logging.getLogger(__name__)

HELP = "local (exploration) planner: time per call over a lap's growing cone views, path inside"

FSG = Path(__file__).resolve().parents[2] / "shared" / "data" / "tracks" / "amz_fssim" / "FSG.yaml"
EXPLORATION_SPEED_MPS = 6.0
"""The car's speed in the views (m/s): their times are the arc length over it."""


@dataclass(frozen=True, slots=True)
class ConeView:
    """One view: the car's pose on the centreline and the cones mapped so far.

    ``seen`` (N,) bool over the track's cones; ``xy_m`` (N, 2) the mapped positions (with the
    view set's noise) of every cone, read where ``seen``."""

    t_s: float
    x_m: float
    y_m: float
    yaw_rad: float
    seen: NDArray[np.bool_]
    xy_m: NDArray[np.float64]


def cone_views(track: Track, step_m: float = 2.0, range_m: float = 20.0,
               fov_rad: float = math.pi / 2.0, noise_m: float = 0.05, seed: int = 1,
               limit: int | None = None) -> list[ConeView]:
    """The growing cone views of one lap along ``track``'s centreline (see the module
    docstring): one every ``step_m`` (m) from the start, at most ``limit``."""
    rng = np.random.default_rng(seed)
    cones = np.asarray(track.cones_xy_m, np.float64)
    noisy = cones + noise_m * rng.standard_normal(cones.shape)
    seen = np.zeros(len(cones), bool)
    views: list[ConeView] = []
    n = int(track.lap_length_m // step_m)
    for k in range(n if limit is None else min(n, limit)):
        s_m = k * step_m
        x, y, yaw = track.point_at(s_m)
        dx, dy = cones[:, 0] - x, cones[:, 1] - y
        bearing = np.arctan2(dy, dx) - yaw
        bearing = (bearing + math.pi) % (2.0 * math.pi) - math.pi
        seen |= (np.hypot(dx, dy) <= range_m) & (np.abs(bearing) <= 0.5 * fov_rad)
        views.append(ConeView(s_m / EXPLORATION_SPEED_MPS, float(x), float(y), float(yaw),
                              seen.copy(), noisy))
    return views


def map_state(view: ConeView, colours: NDArray[np.int64]) -> MapState:
    """The Mapper's state for ``view``: its cones with ``colours`` (N,) of all the track's."""
    idx = np.flatnonzero(view.seen)
    n = len(idx)
    cones = ConeMap(xy_m=view.xy_m[idx], covariance=np.tile(np.eye(2) * 0.01, (n, 1, 1)),
                    colour=colours[idx], size=np.ones(n, np.int64), confidence=np.ones(n),
                    ids=idx.astype(np.int64))
    pose = PoseEstimate(view.t_s, view.x_m, view.y_m, view.yaw_rad, EXPLORATION_SPEED_MPS,
                        0.0, 0.0, np.eye(3) * 1e-4)
    return MapState(view.t_s, pose, cones, loop_closed=False)


def path_inside(track: Track, xy_m: NDArray[np.float64]) -> bool:
    """Does every point of ``xy_m`` (K, 2) lie inside the track's true boundaries?"""
    hint: int | None = None
    for x, y in xy_m:
        _, lateral, seg = track.locate(float(x), float(y), hint)
        hint = seg
        if not -track.right_half_width_m[seg] < lateral < track.left_half_width_m[seg]:
            return False
    return True


@dataclass
class LocalFigures:
    """What one pass over the views measured (times in ms, one per counted call)."""

    colour: str
    views: int = 0
    exploring: int = 0
    closed_at_m: float | None = None
    """Where along the lap (m) the mapped cones closed the loop (exploring ended); None: never."""
    paths: int = 0
    inside: int = 0
    path_ms: list[float] = field(default_factory=list)
    local_ms: list[float] = field(default_factory=list)
    plan_ms: list[float] = field(default_factory=list)

    def summary(self) -> dict[str, Any]:
        """Medians and p99s (ms), counts, the fraction inside and the local/plan ratio."""
        out: dict[str, Any] = {"colour": self.colour, "views": self.views,
                               "exploring": self.exploring, "closed_at_m": self.closed_at_m,
                               "paths": self.paths,
                               "inside": self.inside,
                               "inside_fraction": (round(self.inside / self.paths, 4)
                                                   if self.paths else None)}
        for name, values in (("path", self.path_ms), ("local", self.local_ms),
                             ("plan", self.plan_ms)):
            arr = np.asarray(values)
            out[f"{name}_median_ms"] = round(float(np.median(arr)), 3) if arr.size else None
            out[f"{name}_p99_ms"] = (round(float(np.percentile(arr, 99)), 3) if arr.size
                                     else None)
        local, plan = out["local_median_ms"], out["plan_median_ms"]
        out["local_over_plan"] = round(local / plan, 3) if local and plan else None
        return out


def measure(config: AppConfig, track: Track, views: list[ConeView],
            colour: bool = True) -> LocalFigures:
    """Time the three calls over ``views`` (see the module docstring); ``colour`` False: every
    cone ``UNKNOWN``."""
    colours = np.asarray(track.colours, np.int64)
    if not colour:
        colours = np.full_like(colours, int(ConeColour.UNKNOWN))
    figures = LocalFigures("with colour" if colour else "no colour")
    pc = config.planner
    local = PathPlanner(pc, config.car)
    full = PathPlanner(pc, config.car)
    first = map_state(views[0], colours)
    local.start_autonomous(first)
    full.start_autonomous(first)
    for view in views:
        state = map_state(view, colours)
        figures.views += 1
        pose = state.pose
        t0 = time.perf_counter()
        exploration_path(state.cones.xy_m, state.cones.colour, (pose.x_m, pose.y_m),
                         pose.yaw_rad, track_width_m=pc.nominal_track_width_m,
                         behind_m=ENTRY_BEHIND_M)
        t1 = time.perf_counter()
        made = local.explore(state)
        t2 = time.perf_counter()
        if not local.exploring:  # the loop closed: the lap is mapped, exploring is over
            figures.closed_at_m = view.t_s * EXPLORATION_SPEED_MPS
            break
        full.plan(state, view.t_s)
        t3 = time.perf_counter()
        figures.exploring += 1
        figures.path_ms.append((t1 - t0) * 1e3)
        figures.local_ms.append((t2 - t1) * 1e3)
        figures.plan_ms.append((t3 - t2) * 1e3)
        if made and local.frame is not None:
            figures.paths += 1
            figures.inside += path_inside(track, local.frame.xy_m)
    return figures


def pin_one_cpu() -> tuple[str, set[int] | None]:
    """Pin this process to one CPU (the lowest it may use); returns what was done and the CPUs
    it had (None: unchanged), for :func:`unpin`."""
    if not hasattr(os, "sched_setaffinity"):
        return "not pinned (no sched_setaffinity)", None
    cpus = set(os.sched_getaffinity(0))
    try:
        os.sched_setaffinity(0, {min(cpus)})
    except OSError as exc:
        return f"not pinned ({exc})", None
    return f"pinned to CPU {min(cpus)}", cpus


def unpin(cpus: set[int] | None) -> None:
    """Give the process back the CPUs :func:`pin_one_cpu` took away."""
    if cpus is not None:
        os.sched_setaffinity(0, cpus)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``bench plan_local``."""
    parser.add_argument("--track", default=str(FSG), help="track name or file (default FSG)")
    parser.add_argument("--step-m", type=positive_float, default=2.0,
                        help="metres along the centreline between views (default 2)")
    parser.add_argument("--range-m", type=positive_float, default=None,
                        help="sensor range (m; default the simulated camera's)")
    parser.add_argument("--fov-deg", type=positive_float, default=None,
                        help="field of view (deg; default the simulated camera's)")
    parser.add_argument("--noise-m", type=non_negative_float, default=0.05,
                        help="position noise of a mapped cone (m, default 0.05)")
    parser.add_argument("--seed", type=non_negative_int, default=1, help="noise seed (default 1)")
    parser.add_argument("--views", type=positive_int, default=None,
                        help="at most this many views (default: the whole lap)")


def run(args: argparse.Namespace, config: AppConfig) -> int:
    """Run the benchmark: both colour modes, their figures, last line the local median."""
    from simulator.tracks import load_track

    config = copy.deepcopy(config)
    logging.getLogger("planner").setLevel(logging.ERROR)  # a view without a path is counted
    track = load_track(args.track)
    camera = config.sim.camera
    range_m = args.range_m if args.range_m is not None else camera.max_range_m
    fov_rad = math.radians(args.fov_deg) if args.fov_deg is not None else camera.fov_rad
    views = cone_views(track, args.step_m, range_m, fov_rad, args.noise_m, args.seed,
                       args.views)
    pinned, cpus = pin_one_cpu()
    try:
        results = [measure(config, track, views, colour=c).summary() for c in (True, False)]
    finally:
        unpin(cpus)
    print(f"plan_local: {track.name}, {len(views)} views every {args.step_m:g} m, range "
          f"{range_m:g} m, field of view {math.degrees(fov_rad):.0f} deg, noise "
          f"{args.noise_m:g} m; {pinned}")
    for r in results:
        closed = (f"loop closed at {r['closed_at_m']:.0f} m" if r["closed_at_m"] is not None
                  else "loop never closed")
        print(f"{r['colour']:>12}: {r['exploring']} exploring calls ({closed}), "
              f"{r['paths']} paths, inside {r['inside']} ({r['inside_fraction']}); "
              f"exploration_path median {r['path_median_ms']} ms p99 {r['path_p99_ms']} ms; "
              f"local median {r['local_median_ms']} ms p99 {r['local_p99_ms']} ms; "
              f"full plan median {r['plan_median_ms']} ms p99 {r['plan_p99_ms']} ms; "
              f"local/plan {r['local_over_plan']}")
    coloured, blind = results
    print(f"plan_local_inside_fraction={coloured['inside_fraction']} "
          f"plan_local_inside_fraction_no_colour={blind['inside_fraction']}")
    print(f"plan_local_median_ms={coloured['local_median_ms']}")
    return 0
