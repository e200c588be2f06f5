"""Closed-loop speed: simulated seconds per wall second, and where the time goes (issue 42).

By default the run of ``sim --laps 2 --seed 7 --no-render`` on the default track, recording on
(in its own process, as ``sim`` records), into a temporary folder. Prints the budget table
(:mod:`orchestrator.budget`: wall milliseconds per simulated second in the simulator, sensor
decoding, the Mapper, the planner, the controller and the outputs), then
``realtime_factor=<x>`` (target >= 10).

``--world-only``: the simulated world alone for ``--duration`` s, driven by the ScriptedDriver
(commands at 100 Hz, as the controller would give them), with the time of physics + scoring and
of each sensor model.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from collections import defaultdict
from pathlib import Path
from typing import Any

from common.cli_types import non_negative_int, positive_int, positive_seconds
from orchestrator.config import AppConfig

HELP = "closed-loop sim speed and its budget table (ms per simulated second per stage)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``bench sim``."""
    parser.add_argument("--track", default="default", help="track name or file")
    parser.add_argument("--laps", type=positive_int, default=2, help="autonomous laps (2)")
    parser.add_argument("--seed", type=non_negative_int, default=7)
    parser.add_argument("--no-record", dest="record", action="store_false",
                        help="no recording")
    parser.add_argument("--world-only", action="store_true",
                        help="the simulated world alone, scripted driver, per sensor model")
    parser.add_argument("--duration", type=positive_seconds, default=60.0,
                        help="simulated seconds of --world-only")


class _Timed:
    """Wraps a sensor model and adds its poll time to a shared table."""

    def __init__(self, name: str, model: Any, table: dict[str, float]) -> None:
        self._name = name
        self._model = model
        self._table = table

    def poll(self, *args: Any) -> Any:
        t0 = time.perf_counter()
        out = self._model.poll(*args)
        self._table[self._name] += time.perf_counter() - t0
        return out

    def __getattr__(self, item: str) -> Any:
        return getattr(self._model, item)


def run(args: argparse.Namespace, config: AppConfig) -> int:
    """Run the benchmark; print the budget table (or per-part times) and ``realtime_factor=``."""
    if args.world_only:
        return _world_only(args, config)
    from orchestrator.budget import format_budget
    from orchestrator.sim import SimOptions, run_sim

    with tempfile.TemporaryDirectory(prefix="bench_sim_") as tmp:
        summary = run_sim(config, SimOptions(
            track=args.track, laps=args.laps, seed=args.seed, render=False, record=args.record,
            out_dir=Path(tmp), artifacts=False))
    timing = summary["timing"]
    print(f"track={summary['track']} laps={args.laps} seed={args.seed} "
          f"recording={'on' if args.record else 'off'} finished={summary['finished']} "
          f"lap_times_s={summary['lap_times_s']}")
    print(f"outputs_sha256={summary['outputs_sha256']}")
    print(format_budget(timing["budget"], timing["sim_time_s"], timing["wall_time_s"]))
    print(f"realtime_factor={timing['realtime_factor']:.2f}")
    return 0


def _world_only(args: argparse.Namespace, config: AppConfig) -> int:
    """The world alone (``--world-only``): per-part times and ``realtime_factor=``."""
    from simulator.driver import ScriptedDriver
    from simulator.tracks import load_track
    from simulator.world import SimWorld

    track = load_track(args.track)
    world = SimWorld(config, track, seed=args.seed)
    table: dict[str, float] = defaultdict(float)
    world.models = {name: _Timed(name, m, table) for name, m in world.models.items()}
    driver = ScriptedDriver(track, config.car, seed=args.seed,
                            speed_mps=config.sim.driver_speed_mps)
    control_dt = 0.01
    n = int(round(args.duration / control_dt))
    units = 0
    t_driver = 0.0
    wall0 = time.perf_counter()
    for k in range(1, n + 1):
        t0 = time.perf_counter()
        cmd = driver.command(world.truth(), world.t_s)
        t_driver += time.perf_counter() - t0
        units += len(world.step_to(k * control_dt, cmd))
    wall = time.perf_counter() - wall0
    sensors = sum(table.values())
    print(f"track={track.name} simulated={world.t_s:.1f}s wall={wall:.2f}s units={units}")
    print(f"summary: {world.summary()}")
    print(f"  physics+scoring+sorting: {wall - sensors - t_driver:7.3f} s "
          f"({100 * (wall - sensors - t_driver) / wall:5.1f} %)")
    print(f"  scripted driver:         {t_driver:7.3f} s ({100 * t_driver / wall:5.1f} %)")
    for name, seconds in sorted(table.items(), key=lambda kv: -kv[1]):
        print(f"  {name + ' model:':24s} {seconds:7.3f} s ({100 * seconds / wall:5.1f} %)")
    print(f"realtime_factor={world.t_s / wall:.2f}")
    return 0
