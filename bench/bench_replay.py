"""Replay ``--max`` of the sample recording through the whole stack, no rendering (issue 5).

Prints the wall and CPU time of the replay (CPU of Main's process; the front end that reads the
recording and runs the Sensor Manager works in a second process beside it, see
:mod:`orchestrator.replay_front`), the realtime factor (recording seconds per wall second; the
issue asks for at least 20), the time of each stage of Main's tick and of the front end, and
whether the replay reproduced the recorded run's ``outputs_sha256``. ``--single-process`` runs
the front end in Main's process (the replay's ``--single-process``). With
``--profile`` it also runs cProfile and prints where the time goes by package and by function
(the profiler itself slows the run about 2-3x; its shares, not its seconds, are the figure).
The last line is ``realtime_factor=<x>``.
"""

from __future__ import annotations

import argparse
import cProfile
import json
import pstats
import time
from collections import defaultdict
from pathlib import Path
from typing import Any

from common.cli_types import positive_int
from orchestrator.config import AppConfig

HELP = "replay --max of the sample recording: realtime factor and stage timings"
TARGET_REALTIME_FACTOR = 20.0
ROOT = Path(__file__).resolve().parents[1]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--recording", type=Path, default=None,
                        help="replay this recording instead of the sample")
    parser.add_argument("--profile", action="store_true",
                        help="also run under cProfile and print where the time goes")
    parser.add_argument("--top", type=positive_int, default=25,
                        help="functions listed with --profile")
    parser.add_argument("--single-process", action="store_true",
                        help="run the front end in Main's process (no second process)")


def run(args: argparse.Namespace, config: AppConfig) -> int:
    from orchestrator.replay import ReplayOptions, run_replay
    from orchestrator.sample import sample_recording_path, summary_path

    path: Path = args.recording or sample_recording_path()
    expected = None
    if args.recording is None and summary_path(path).exists():
        expected = json.loads(summary_path(path).read_text()).get("outputs_sha256")
    size_mb = path.stat().st_size / 1e6

    wall0, cpu0 = time.perf_counter(), time.process_time()
    summary = run_replay(config, ReplayOptions(path, pipeline=not args.single_process))
    wall_s, cpu_s = time.perf_counter() - wall0, time.process_time() - cpu0
    timing = summary["timing"]
    sim_s = float(timing["sim_time_s"])
    ticks = int(summary["ticks"])
    factor = sim_s / wall_s

    print(f"recording: {path} ({size_mb:.1f} MB, {sim_s:.2f} s, {ticks} ticks)")
    print(f"replay --max: wall {wall_s:.2f} s, cpu {cpu_s:.2f} s "
          f"(realtime factor {factor:.2f} wall, {sim_s / cpu_s:.2f} cpu; "
          f"target {TARGET_REALTIME_FACTOR:.0f})")
    print(_stage_table(timing["stages_ms"], wall_s))
    front = timing.get("front_end", {})
    if front:
        where = "its own process, beside Main" if front.get("pipelined") else "Main's process"
        print(f"front end ({where}): reading+decoding the recording {front['read_s']:.2f} s, "
              f"sensor manager (parsers, detector, health) {front['sensors_s']:.2f} s")
    if expected is not None:
        same = summary["outputs_sha256"] == expected
        print("outputs_sha256 equals the run that made the sample: "
              + ("yes" if same else "no (the stack's code changed since it was made?)"))
    if args.profile:
        _profile(config, path, args.top)
    print(f"realtime_factor={factor:.2f}")
    return 0


def _stage_table(stages_ms: dict[str, dict[str, float]], wall_s: float) -> str:
    """Seconds and share of the wall time per stage of Main's tick; 'rest of loop' is the
    replay loop around it (waiting for and receiving the front end's ticks, or running the
    front end when it is not pipelined)."""
    lines = [f"{'stage':<14} {'count':>6} {'total_s':>8} {'share':>6} {'mean_ms':>8} "
             f"{'p99_ms':>8} {'max_ms':>8}"]

    def row(name: str, total_s: float, data: dict[str, float] | None = None) -> str:
        text = f"{name:<14} {int(data['count']) if data else '':>6} {total_s:8.2f} " \
               f"{total_s / wall_s:6.1%}"
        if data:
            text += f" {data['mean_ms']:8.3f} {data['p99_ms']:8.3f} {data['max_ms']:8.3f}"
        return text

    parts = 0.0
    for stage in ("sensors", "mapper", "planner", "health", "controller", "outputs"):
        data = stages_ms.get(stage)
        if data is not None:
            parts += data["total_s"]
            lines.append(row(stage, data["total_s"], data))
    tick = stages_ms.get("tick")
    tick_s = tick["total_s"] if tick else 0.0
    lines.append(row("tick (rest)", tick_s - parts))
    if tick:
        lines.append(row("tick (all)", tick_s, tick))
    lines.append(row("rest of loop", wall_s - tick_s))
    return "\n".join(lines)


def _package(filename: str) -> str:
    try:
        rel = Path(filename).resolve().relative_to(ROOT)
    except ValueError:
        if "site-packages" in filename:
            return "lib:" + filename.split("site-packages/")[1].split("/")[0]
        return "python" if filename != "~" else "builtins (C)"
    return str(rel.parts[0]) if len(rel.parts) > 1 else str(rel)


def _profile(config: AppConfig, path: Path, top: int) -> None:
    """cProfile the replay; print inclusive time of the main entry points and the top
    functions by own time, and own time summed per package."""
    from orchestrator.replay import ReplayOptions, run_replay

    profiler = cProfile.Profile()
    profiler.enable()
    run_replay(config, ReplayOptions(path, pipeline=False))  # the whole stack in one profile
    profiler.disable()
    stats = pstats.Stats(profiler)
    raw: dict[Any, Any] = stats.stats  # type: ignore[attr-defined]
    total = max(stats.total_tt, 1e-9)  # type: ignore[attr-defined]

    entry_points = {
        ("main_loop.py", "tick"): "Main.tick (all stages)",
        ("mapper.py", "update"): "Mapper.update",
        ("ekf.py", "update"): "  EKF SLAM Kalman update",
        ("ekf_slam.py", "update_cones"): "  EKF SLAM cone update",
        ("ukf_localiser.py", "predict"): "  UKF predict",
        ("manager.py", "ingest"): "SensorManager.ingest (parsers)",
        ("lidar_parser.py", "feed"): "  LiDAR parser (decode+detect)",
        ("cone_detector.py", "detect"): "    cone detector",
        ("manager.py", "health"): "SensorManager.health",
        ("controller.py", "command"): "Controller.command",
        ("path_planner.py", "plan"): "PathPlanner.plan",
        ("player.py", "__iter__"): "Player (read+decode)",
        ("outputs.py", "write"): "output hashing",
    }
    print(f"\nprofile (cProfile, {total:.2f} s profiled): inclusive time of entry points")
    found = []
    for (filename, _line, name), (_cc, _nc, _tt, ct, _callers) in raw.items():
        label = entry_points.get((Path(filename).name, name))
        if label is not None:
            found.append((list(entry_points.values()).index(label), label, ct))
    for _i, label, ct in sorted(found):
        print(f"  {label:<34} {ct:7.2f} s {ct / total:6.1%}")

    per_package: dict[str, float] = defaultdict(float)
    for (filename, _line, _name), (_cc, _nc, tt, _ct, _callers) in raw.items():
        per_package[_package(filename)] += tt
    print("own time per package (numpy/scipy time counts where it is spent, not its caller)")
    for package, tt in sorted(per_package.items(), key=lambda kv: -kv[1])[:12]:
        print(f"  {package:<34} {tt:7.2f} s {tt / total:6.1%}")
    print(f"top {top} functions by own time")
    rows = sorted(raw.items(), key=lambda kv: -kv[1][2])[:top]
    for (filename, line, name), (_cc, nc, tt, ct, _callers) in rows:
        where = f"{_package(filename)}:{Path(filename).name}:{line}({name})"
        print(f"  {tt:7.2f} s {tt / total:6.1%} cum {ct:7.2f} s  calls {nc:>7}  {where}")
