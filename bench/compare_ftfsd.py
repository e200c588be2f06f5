"""Our local planner beside FaSTTUBe's ft-fsd-path-planning on the very same cone views.

``bench plan_local`` builds the growing cone views of one exploration lap (the car stepping
along the true centreline, each cone mapped once it has been in the camera's range and field
of view, with seeded position noise) and scores our local planner on them. This script runs
the same views through ``fsd_path_planning.PathPlanner.calculate_path_in_global_frame``
(autocross mission, a fresh planner per lap as its README asks) and scores its path the same
way: is every point of it inside the true boundaries; time per call on one pinned CPU, after a
warm-up that compiles its Numba functions. Both with the cones' true colours and with every
colour removed (``UNKNOWN``).

ft-fsd-path-planning is not a dependency of this project (it needs numba and scikit-learn).
Install it beside the project in a separate environment::

    python3 -m venv /tmp/ftfsd && /tmp/ftfsd/bin/pip install -e . \\
        "fsd-path-planning @ git+https://github.com/papalotis/ft-fsd-path-planning.git"
    /tmp/ftfsd/bin/python -m bench.compare_ftfsd [--track FSG.yaml] [--step-m 2]

It prints one line per planner and colour mode: views, paths, the fraction inside, the call's
median and p99 (ms).
"""

from __future__ import annotations

import argparse
import copy
import importlib
import logging
import math
import time
from typing import Any

import numpy as np
from numpy.typing import NDArray

from bench.bench_plan_local import (
    FSG,
    ConeView,
    cone_views,
    measure,
    path_inside,
    pin_one_cpu,
    unpin,
)
from common.messages import ConeColour
from orchestrator.config import load_config
from simulator.track import Track
from simulator.tracks import load_track

WARM_UP_CALLS = 3
"""Calls before timing: the first compiles ft-fsd's Numba functions (30-60 s)."""


def ftfsd_cone_lists(view: ConeView, colours: NDArray[np.int64]) -> list[NDArray[np.float64]]:
    """ft-fsd's input: five (N, 2) arrays, indexed by its ConeTypes (0 unknown, 1 right =
    yellow, 2 left = blue, 3 small orange, 4 big orange), of the cones ``view`` has mapped."""
    xy = view.xy_m[view.seen]
    col = colours[view.seen]
    order = (ConeColour.UNKNOWN, ConeColour.YELLOW, ConeColour.BLUE, ConeColour.ORANGE,
             ConeColour.BIG_ORANGE)
    return [xy[col == int(c)].reshape(-1, 2) for c in order]


def _ftfsd() -> Any:
    """The ``fsd_path_planning`` package, imported by name: it is an optional tool beside this
    project, not one of its dependencies."""
    try:
        return importlib.import_module("fsd_path_planning")
    except ImportError:
        raise SystemExit("ft-fsd-path-planning is not installed here: install it beside the "
                         "project as the docstring of bench/compare_ftfsd.py says") from None


def measure_ftfsd(track: Track, views: list[ConeView], colour: bool) -> dict[str, float | int]:
    """ft-fsd over ``views``: calls, paths, paths inside, median and p99 time (ms)."""
    ftfsd = _ftfsd()
    MissionTypes, PathPlanner = ftfsd.MissionTypes, ftfsd.PathPlanner  # noqa: N806

    colours = np.asarray(track.colours, np.int64)
    if not colour:
        colours = np.full_like(colours, int(ConeColour.UNKNOWN))
    planner = PathPlanner(MissionTypes.autocross)
    for view in views[:WARM_UP_CALLS]:
        planner.calculate_path_in_global_frame(ftfsd_cone_lists(view, colours),
                                               np.array([view.x_m, view.y_m]), view.yaw_rad)
    planner = PathPlanner(MissionTypes.autocross)
    times_ms: list[float] = []
    paths = inside = 0
    for view in views:
        cones = ftfsd_cone_lists(view, colours)
        t0 = time.perf_counter()
        try:
            path = planner.calculate_path_in_global_frame(
                cones, np.array([view.x_m, view.y_m]), view.yaw_rad)
        except Exception as exc:  # noqa: BLE001 - a failed call is counted as no path
            logging.debug("ft-fsd: no path at t=%.1f s: %s", view.t_s, exc)
            path = None
        times_ms.append((time.perf_counter() - t0) * 1e3)
        if path is not None and len(path):
            paths += 1
            inside += path_inside(track, np.asarray(path)[:, 1:3])
    arr = np.asarray(times_ms)
    return {"views": len(views), "paths": paths, "inside": inside,
            "inside_fraction": round(inside / paths, 4) if paths else math.nan,
            "median_ms": round(float(np.median(arr)), 2),
            "p99_ms": round(float(np.percentile(arr, 99)), 2)}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--track", default=str(FSG), help="track name or file (default FSG)")
    parser.add_argument("--step-m", type=float, default=2.0, help="metres between views")
    parser.add_argument("--noise-m", type=float, default=0.05, help="cone position noise (m)")
    parser.add_argument("--seed", type=int, default=1, help="noise seed")
    args = parser.parse_args(argv)
    _ftfsd()  # before the long part: a missing package is said at once
    logging.basicConfig(level=logging.WARNING)
    logging.getLogger("planner").setLevel(logging.ERROR)
    config = copy.deepcopy(load_config(None))
    track = load_track(args.track)
    camera = config.sim.camera
    views = cone_views(track, args.step_m, camera.max_range_m, camera.fov_rad, args.noise_m,
                       args.seed)
    pinned, cpus = pin_one_cpu()
    try:
        for colour in (True, False):
            ours = measure(config, track, views, colour=colour).summary()
            # the same views as ours: up to where the mapped cones closed the loop
            theirs = measure_ftfsd(track, views[:ours["exploring"]], colour)
            mode = "with colour" if colour else "no colour"
            print(f"{mode:>12} ours  : {ours['exploring']} views, {ours['paths']} paths, "
                  f"inside {ours['inside_fraction']}, local median {ours['local_median_ms']} "
                  f"ms p99 {ours['local_p99_ms']} ms")
            print(f"{mode:>12} ft-fsd: {theirs['views']} views, {theirs['paths']} paths, "
                  f"inside {theirs['inside_fraction']}, median {theirs['median_ms']} ms "
                  f"p99 {theirs['p99_ms']} ms")
    finally:
        unpin(cpus)
    print(f"{track.name}: views every {args.step_m:g} m, noise {args.noise_m:g} m, "
          f"seed {args.seed}; {pinned}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
