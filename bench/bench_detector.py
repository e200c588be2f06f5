"""``python main.py bench detector``: LiDAR cone detection time per full VLP-16 sweep.

Sweeps come from the simulated VLP-16 (simulator/lidar_model.py, default noise) driving round
a circular track of cones, decoded by sensors/velodyne.py. The simulated world has no trees or
barriers, so the upward lasers return nothing; each sweep gets the returns of a surrounding
wall 40 m away on those rays (within 110 deg of ahead; the rest sees the car body), which
brings it to a full sweep of about 29 000 returns. Each sweep is detected ``--repeat`` times;
the median time per sweep is reported, with the same figure for a simple reference measured
in the same run: ground removal plus Euclidean clustering of the remaining points (scipy
cKDTree, connected components), the usual baseline cone detector. numpy's element-wise work
runs on one core.
"""

from __future__ import annotations

import argparse
import math
import statistics
import time
from types import SimpleNamespace

import numpy as np

from common.cli_types import positive_int
from common.messages import ConeSize, GroundTruth, LidarPoints
from orchestrator.config import AppConfig
from sensors.cone_detector import ConeDetector
from sensors.lidar_parser import LidarParser
from sensors.velodyne import RING_ELEVATION_DEG
from simulator.lidar_model import LidarModel

HELP = "LiDAR cone detection: median ms per full 29 000-point sweep"
RADIUS_M = 15.0


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of the benchmark."""
    parser.add_argument("--sweeps", type=positive_int, default=10,
                        help="simulated sweeps (default 10)")
    parser.add_argument("--repeat", type=positive_int, default=10, help="detections per sweep")


def _track() -> SimpleNamespace:
    cones, sizes = [], []
    for r in (RADIUS_M - 1.75, RADIUS_M + 1.75):
        n = int(round(2 * math.pi * r / 4.0))
        for i in range(n):
            a = 2 * math.pi * i / n - math.pi / 2
            cones.append((r * math.cos(a), RADIUS_M + r * math.sin(a)))
            sizes.append(int(ConeSize.LARGE) if i in (0, n - 1) else int(ConeSize.SMALL))
    return SimpleNamespace(cones_xy_m=np.array(cones), sizes=np.array(sizes))


def _sweeps(config: AppConfig, count: int) -> list[LidarPoints]:
    model = LidarModel(config, np.random.default_rng(1))
    # every return, as before the window
    parser = LidarParser(config.sensors.lidar, config.car, all_points=True)
    track = _track()
    speed = 8.0
    rate = speed / RADIUS_M
    sweeps: list[LidarPoints] = []
    t = 0.0
    while len(sweeps) < count + 1:
        t += 0.005
        yaw = rate * t
        truth = GroundTruth(t, RADIUS_M * math.sin(yaw), RADIUS_M * (1 - math.cos(yaw)), yaw,
                            speed, 0.0, rate)
        for raw in model.poll(t, truth, None, track):
            if parser.feed(raw.timestamp_s, raw.payload) and parser.last_sweep is not None:
                sweeps.append(_with_wall(parser.last_sweep))
    return sweeps[1:]  # the first one is partial


def _with_wall(sweep: LidarPoints) -> LidarPoints:
    """Add returns from a wall 40 m away on the upward rays (which hit nothing in the sim)."""
    up = np.flatnonzero(RING_ELEVATION_DEG > 0)
    az = np.radians(np.arange(-110.0, 110.0, 0.2))  # the rest of the view is the car body
    el = np.radians(RING_ELEVATION_DEG[up])
    r = 40.0
    a, e = np.meshgrid(az, el)
    wall = np.c_[(r * np.cos(e) * np.cos(a)).ravel(), (-r * np.cos(e) * np.sin(a)).ravel(),
                 (r * np.sin(e)).ravel(), np.full(a.size, 20.0)]
    rings = np.repeat(up, az.size)
    times = np.full(a.size, sweep.times_s.mean())
    return LidarPoints(sweep.timestamp_s, np.r_[sweep.points, wall], np.r_[sweep.times_s, times],
                       np.r_[sweep.rings, rings])


def _reference(points: np.ndarray, lidar_z_m: float) -> int:
    """Baseline: ground removal by height, Euclidean clustering (0.3 m) of the rest."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    z = points[:, 2] + lidar_z_m
    r = np.hypot(points[:, 0], points[:, 1])
    ahead = np.abs(np.arctan2(points[:, 1], points[:, 0])) < math.radians(120.0)
    keep = (z > 0.05) & (z < 0.7) & (r > 1.0) & (r < 15.0) & ahead
    xy = points[keep, :2]
    pairs = cKDTree(xy).query_pairs(0.3, output_type="ndarray")
    n = xy.shape[0]
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    count, labels = connected_components(graph, directed=False)
    sizes = np.bincount(labels)
    return int(np.sum((sizes >= 3) & (sizes < 200)))


def run(args: argparse.Namespace, config: AppConfig) -> int:
    """Simulate, then time the detector and the reference on the same sweeps."""
    sweeps = _sweeps(config, max(1, args.sweeps))
    detector = ConeDetector(config.sensors.lidar.detector, config.car)
    ours: list[float] = []
    ref: list[float] = []
    cones = 0
    for sweep in sweeps:
        for _ in range(max(1, args.repeat)):
            t0 = time.perf_counter()
            out = detector.detect(sweep.points, sweep.rings, sweep.times_s, sweep.timestamp_s)
            ours.append(time.perf_counter() - t0)
            t0 = time.perf_counter()
            _reference(sweep.points, config.car.lidar_z_m)
            ref.append(time.perf_counter() - t0)
        cones += len(out.cones)
    points = statistics.median(s.points.shape[0] for s in sweeps)
    ours_ms = 1e3 * statistics.median(ours)
    ref_ms = 1e3 * statistics.median(ref)
    print(f"sweeps={len(sweeps)} median_points={points:.0f} "
          f"cones_per_sweep={cones / len(sweeps):.1f}")
    print(f"reference_euclidean_clustering_ms={ref_ms:.3f}")
    print(f"speedup_vs_reference={ref_ms / ours_ms:.2f}")
    print(f"median_ms={ours_ms:.3f}")
    return 0
