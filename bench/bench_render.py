"""``python main.py bench render``: frames per second at 1280x720 including PNG writing, and
what rendering beside a 100 Hz control loop does to that loop's 99th-percentile period."""

from __future__ import annotations

import argparse
import math
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from common.cli_types import positive_int, positive_seconds, size_wxh
from common.messages import (
    ActuatorCommand,
    Baseframe,
    ConeMap,
    MapState,
    Plan,
    PoseEstimate,
    TargetStates,
)
from orchestrator.config import AppConfig

HELP = "renderer frames/s at 1280x720 with PNG writing; control-loop p99 with rendering on"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--frames", type=positive_int, default=120, help="frames to render")
    parser.add_argument("--size", type=size_wxh, default="1280x720", help="WxH")
    parser.add_argument("--loop-seconds", type=positive_seconds, default=2.0,
                        help="length of each control-loop measurement (s)")
    parser.add_argument("--rounds", type=positive_int, default=5,
                        help="interleaved rounds without and with rendering")


def synthetic_scene(t_s: float, n_cones: int = 300) -> tuple[MapState, Plan, ActuatorCommand]:
    """A 300-cone oval with a car going round it, a baseframe and 9 candidate manoeuvres."""
    rng = np.random.default_rng(0)
    s = np.linspace(0, 2 * math.pi, n_cones // 2, endpoint=False)
    inner = np.stack([38 * np.cos(s), 18 * np.sin(s)], axis=1)
    outer = np.stack([42 * np.cos(s), 22 * np.sin(s)], axis=1)
    xy = np.concatenate([inner, outer]) + rng.normal(0, 0.02, (n_cones, 2))
    colours = np.r_[np.full(n_cones // 2, 1), np.full(n_cones // 2, 2)]
    cov = np.tile(np.diag([0.01, 0.004]), (n_cones, 1, 1))
    cones = ConeMap(xy, cov, colours, np.ones(n_cones), rng.uniform(1, 20, n_cones),
                    np.arange(n_cones))
    a = 0.3 * t_s
    pose = PoseEstimate(t_s, 40 * math.cos(a), 20 * math.sin(a), a + math.pi / 2, 10.0,
                        covariance=np.diag([0.02, 0.02, 0.001]))
    u = np.linspace(0, 2 * math.pi, 400)
    base = Baseframe(u * 30, 40 * np.cos(u), 20 * np.sin(u), u, np.full(400, 0.03))
    ahead = np.linspace(0, 0.4, 20)
    candidates = tuple(
        np.stack([(40 + d) * np.cos(a + ahead), (20 + d) * np.sin(a + ahead)], axis=1)
        for d in np.linspace(-1.5, 1.5, 9)
    )
    n = 20
    manoeuvre = TargetStates(t_s + np.arange(n) * 0.1, candidates[4][:, 0], candidates[4][:, 1],
                             np.zeros(n), np.full(n, 10.0), np.zeros(n))
    plan = Plan(t_s, base, manoeuvre, 10.0, candidates, 4, xy[::10])
    return MapState(t_s, pose, cones, True, "bench"), plan, ActuatorCommand(t_s, 0.3, 0.0, 0.1)


def paced_loop_periods_ms(seconds: float, on_tick: Callable[[int], None]) -> np.ndarray:
    """Periods (ms) of a 100 Hz loop run for ``seconds`` that does a little numpy work per
    tick (a stand-in for the control loop), then ``on_tick(k)`` for tick ``k``."""
    period = 0.01
    work = np.random.default_rng(1).normal(size=(60, 60))
    periods = []
    next_t = time.perf_counter()
    last = next_t
    k = 0
    end = next_t + seconds
    while next_t < end:
        next_t += period
        delay = next_t - time.perf_counter()
        if delay > 0:
            time.sleep(delay)
        now = time.perf_counter()
        periods.append(now - last)
        last = now
        np.linalg.cholesky(work @ work.T + np.eye(60))
        on_tick(k)
        k += 1
    return np.asarray(periods[1:]) * 1e3


def _loop_periods(seconds: float, visualiser: object | None) -> np.ndarray:
    """The paced loop submitting a frame every 10 ticks."""
    scenes = [synthetic_scene(0.1 * k) for k in range(10)]

    def tick(k: int) -> None:
        if visualiser is not None and k % 10 == 0:
            visualiser.submit(*scenes[(k // 10) % 10])  # type: ignore[attr-defined]

    return paced_loop_periods_ms(seconds, tick)


def run(args: argparse.Namespace, config: AppConfig) -> int:
    from visualiser.offline import PngWriter
    from visualiser.visualiser import FrameRenderer, Visualiser, frame_file_name

    width, height = args.size
    renderer = FrameRenderer(width, height)
    from visualiser.frame_data import frame_from_messages

    frames = [frame_from_messages(*synthetic_scene(0.05 * k)) for k in range(args.frames)]
    with tempfile.TemporaryDirectory() as tmp:
        writer = PngWriter(renderer)
        t0 = time.perf_counter()
        for frame in frames:
            renderer.render(frame)
            writer.write(Path(tmp) / frame_file_name(frame.t_s))
        writer.close()
        elapsed = time.perf_counter() - t0
        fps = len(frames) / elapsed
        print(f"rendered {len(frames)} frames at {width}x{height} with PNG writing in "
              f"{elapsed:.2f} s")

        # Interleaved rounds (off, on, off, on, ...) so that other load on the machine falls on
        # both alike; the renderer process lives through all of them.
        config.visualiser.fps = 10.0
        off: list[float] = []
        on: list[float] = []
        dropped = 0
        with Visualiser(config.visualiser, Path(tmp) / "live") as vis:
            time.sleep(1.0)  # let the renderer process start
            for _ in range(args.rounds):
                off.append(float(np.percentile(_loop_periods(args.loop_seconds, None), 99)))
                on.append(float(np.percentile(_loop_periods(args.loop_seconds, vis), 99)))
            dropped = vis.dropped
        p99_base = float(np.median(off))
        p99_loaded = float(np.median(on))
        print(f"control loop p99 period (median of {args.rounds} interleaved rounds): "
              f"{p99_base:.3f} ms without rendering, {p99_loaded:.3f} ms with rendering at "
              f"10 fps in its process (delta {p99_loaded - p99_base:+.3f} ms; "
              f"{dropped} frames dropped)")
        print(f"loop_p99_delta_ms={p99_loaded - p99_base:.3f}")
    print(f"fps={fps:.1f}")
    return 0
