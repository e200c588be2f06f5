"""EKF SLAM loop closure on generated tracks: ``python main.py bench slam_loops --tracks 20``.

For each seed, a generated trackdrive layout (``simulator.track_generator`` when present, else
:func:`bench.slam_sim.generated_loop`), one lap plus a little of this benchmark's own simulation
(IMU 200 Hz, wheels 100 Hz, GPS 2.5 m at 10 Hz, LiDAR cones at 10 Hz with 2 cm range noise, 10 %
missed and 5 % false cones, camera colours), then the map and pose metrics. Last line
``closed=<closed>/<tracks> worst_map_rmse_m=<x> worst_false_fraction=<y>``.
"""

from __future__ import annotations

import argparse
import time

from bench import slam_sim
from common.cli_types import non_negative_int, positive_int
from mapper.slam.blas import limit_blas_threads
from orchestrator.config import AppConfig

HELP = "EKF SLAM loop closure and map quality on generated tracks"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``bench slam_loops``."""
    parser.add_argument("--tracks", type=positive_int, default=20,
                        help="number of generated tracks")
    parser.add_argument("--first-seed", type=non_negative_int, default=0)


def run(args: argparse.Namespace, config: AppConfig) -> int:
    """Run one lap on each generated track; print one row per track."""
    limit_blas_threads(1)
    closed = 0
    worst_rmse, worst_false = 0.0, 0.0
    print(f"{'seed':>4} {'lap_m':>6} {'closed':>6} {'map_rmse_m':>10} {'false':>5} {'missed':>6} "
          f"{'true':>5} {'pose_rmse_m':>11} {'nees_in_band':>12} {'slam_s':>6} {'sim_s':>6}")
    for seed in range(args.first_seed, args.first_seed + args.tracks):
        scenario = slam_sim.generated_loop(seed)
        sim = slam_sim.simulate(scenario, config.car, seed=seed)
        t0 = time.perf_counter()
        result = slam_sim.run_slam(sim, config.mapper, config.car)
        wall = time.perf_counter() - t0
        m, p = result.map_metrics, result.pose_metrics
        closed += int(result.slam.loop_closed)
        worst_rmse = max(worst_rmse, m["rmse_m"])
        worst_false = max(worst_false, m["false_landmarks"] / max(m["true_cones"], 1))
        print(f"{seed:>4} {sim.trajectory.lap_length_m:>6.0f} {result.slam.loop_closed!s:>6} "
              f"{m['rmse_m']:>10.3f} {m['false_landmarks']:>5} {m['missed_cones']:>6} "
              f"{m['true_cones']:>5} {p['pose_rmse_m']:>11.3f} {result.nees_in_band:>12.2f} "
              f"{wall:>6.2f} {sim.trajectory.t_s[-1]:>6.1f}", flush=True)
    print(f"closed={closed}/{args.tracks} worst_map_rmse_m={worst_rmse:.3f} "
          f"worst_false_fraction={worst_false:.3f}")
    return 0 if closed == args.tracks else 1
