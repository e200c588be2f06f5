"""EKF SLAM sweep update: ours (sparse H, Cholesky, P - K(HP)) against the textbook step.

``python main.py bench slam --landmarks 300``: one sweep's batched update of ``--cones``
associated detections on a filter with ``--landmarks`` landmarks, ours against the textbook EKF
(full H, explicit inverse, full n x n covariance update in filterpy's Joseph form) on identical
input in the same run; PythonRobotics' simpler ``(I - K H) P`` is timed too and printed. Last line
``speedup=<filterpy-form time / ours> max_abs_diff=<x and P, largest of both references>``.

Ours leaves the upper triangle of P's landmark block stale after an update (the lower one is
the covariance; :meth:`mapper.slam.ekf.SlamEkf.update`) and mirrors it when the whole ``P`` is
read; ``max_abs_diff`` is taken on that symmetric ``P``, and a diagnostic line times the update
together with that read.
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

from bench.textbook_ekf import textbook_update
from common.cli_types import non_negative_int, positive_int
from common.messages import ConeDetection
from mapper.slam.blas import limit_blas_threads
from mapper.slam.ekf_slam import EkfSlam
from mapper.slam.models import POSE_DIM, observation_model
from orchestrator.config import AppConfig

HELP = "EKF SLAM sweep update: ours against the textbook EKF step"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``bench slam``."""
    parser.add_argument("--landmarks", type=positive_int, default=300,
                        help="landmarks in the filter")
    parser.add_argument("--cones", type=positive_int, default=20,
                        help="associated detections per sweep")
    parser.add_argument("--repeats", type=positive_int, default=30, help="timed repetitions")
    parser.add_argument("--seed", type=non_negative_int, default=0)
    parser.add_argument("--threads", type=non_negative_int, default=1,
                        help="BLAS threads for both (0 leaves the library default)")


def _problem(landmarks: int, cones: int, seed: int
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A filter state with landmarks around a lap, a realistic SPD covariance and one sweep."""
    rng = np.random.default_rng(seed)
    n = POSE_DIM + 2 * landmarks
    ang = np.linspace(0.0, 2 * math.pi, landmarks, endpoint=False)
    radius = 40.0 + 1.75 * np.where(np.arange(landmarks) % 2 == 0, 1.0, -1.0)
    lm = np.stack([radius * np.cos(ang), radius * np.sin(ang) + 40.0], axis=1)
    lm += rng.normal(0.0, 0.05, lm.shape)
    x = np.zeros(n)
    x[:POSE_DIM] = [0.0, 0.0, 0.0, 8.0, 0.0]
    x[POSE_DIM:] = lm.ravel()
    b = rng.normal(0.0, 1.0, (n, n)) * 0.004
    p = b @ b.T + np.eye(n) * 1e-4
    # The nearest landmarks ahead are the sweep's cones.
    ahead = np.flatnonzero(lm[:, 0] > 1.0)
    order = ahead[np.argsort(np.hypot(lm[ahead, 0], lm[ahead, 1]))][:cones]
    zhat, _, _ = observation_model(x[:3], lm[order])
    z = zhat + rng.normal(0.0, 0.02, zhat.shape)
    r = np.tile(np.eye(2) * 0.02 ** 2, (order.size, 1, 1))
    return x, p, z, r, order.astype(np.int64)


def run(args: argparse.Namespace, config: AppConfig) -> int:
    """Time both updates on identical input; check they agree."""
    if args.threads > 0:
        limit_blas_threads(args.threads)
    x0, p0, z, r, idx = _problem(args.landmarks, args.cones, args.seed)
    slam = EkfSlam(config.mapper, config.car)
    ours_s, ref_s, simple_s = [], [], []
    for _ in range(args.repeats):
        slam.load_state(x0, p0)
        t0 = time.perf_counter()
        slam.update_landmarks(z, r, idx)
        ours_s.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        x_ref, p_ref = textbook_update(x0, p0, z, r, idx, "joseph")
        ref_s.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        x_simple, p_simple = textbook_update(x0, p0, z, r, idx, "simple")
        simple_s.append(time.perf_counter() - t0)
    diff = max(float(np.max(np.abs(slam.x - x_ref))), float(np.max(np.abs(slam.P - p_ref))),
               float(np.max(np.abs(slam.x - x_simple))), float(np.max(np.abs(slam.P - p_simple))))
    # A whole sweep through the public API (association by Mahalanobis + Hungarian included).
    dets = tuple(ConeDetection(0.0, float(a), float(b)) for a, b in z)
    sweep_s = []
    for _ in range(args.repeats):
        slam.load_state(x0, p0)
        t0 = time.perf_counter()
        slam.update_cones(dets, 0.0)
        sweep_s.append(time.perf_counter() - t0)
    # Diagnostic only: the update followed by a read of the whole P, which pays the lazy mirror
    # of the landmark block's upper triangle (the car's loop never reads the whole P per
    # sweep); the reference runs in between, as above, so the cache is as cold.
    full_s = []
    for _ in range(args.repeats):
        slam.load_state(x0, p0)
        t0 = time.perf_counter()
        slam.update_landmarks(z, r, idx)
        _ = slam.P
        full_s.append(time.perf_counter() - t0)
        textbook_update(x0, p0, z, r, idx, "joseph")
    ours, ref, simple, sweep, full = (float(np.median(v)) * 1e3
                                      for v in (ours_s, ref_s, simple_s, sweep_s, full_s))
    n = POSE_DIM + 2 * args.landmarks
    print(f"state {n}, landmarks {args.landmarks}, detections {idx.size}, "
          f"repeats {args.repeats}, BLAS threads {args.threads or 'default'}")
    print(f"textbook, filterpy form (Joseph):          {ref:8.3f} ms (median)")
    print(f"textbook, PythonRobotics form ((I-KH)P):   {simple:8.3f} ms (median), "
          f"speedup {simple / ours:.1f}")
    print(f"ours (sparse H, Cholesky, P-K(HP)):        {ours:8.3f} ms (median)")
    print(f"ours whole sweep with association:         {sweep:8.3f} ms (median)")
    print(f"ours, then the whole P read (lazy mirror):  {full:8.3f} ms (median), "
          f"speedup {ref / full:.1f}")
    print(f"speedup={ref / ours:.1f} max_abs_diff={diff:.3g}")
    return 0 if diff <= 1e-6 else 1
