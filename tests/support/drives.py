"""Simulated drives for the Mapper's tests: the simulator's car (support.sim_drive), made
once per session, and what tests need around them: which true cone each LiDAR detection is,
and a LiDAR stream with more missed and false cones than the simulated sensor makes."""

from __future__ import annotations

import dataclasses
import functools
import math

import numpy as np

from common.conventions import world_to_vehicle
from common.messages import ConeDetection, LidarCones, Reading
from orchestrator.config import AppConfig
from support.sim_drive import Drive, simulated_drive

FSG = "tracks/amz_fssim/FSG.yaml"
ACCELERATION = "tracks/eufs/acceleration.csv"


@functools.lru_cache(maxsize=16)
def drive(track: str = "default", seed: int = 1, seconds: float | None = None,
          start_heading_enu_rad: float = 0.0, gyro_bias_sigma_radps: float | None = None,
          gps_bias_sigma_m: float | None = None) -> Drive:
    """The exploration lap (or its first ``seconds``) of ``track`` with the simulator's
    defaults but these (a shared-data track as its path under ``../shared/data``). Cached:
    treat it as read-only."""
    config = AppConfig()
    config.sim.start_heading_enu_rad = start_heading_enu_rad
    if gyro_bias_sigma_radps is not None:
        config.sim.imu.gyro_bias_sigma_radps = gyro_bias_sigma_radps
    if gps_bias_sigma_m is not None:
        config.sim.gps.bias_sigma_m = gps_bias_sigma_m
    if track.startswith("tracks/"):
        from support.shared_data import shared_data

        track = str(shared_data(*track.split("/")))
    return simulated_drive(config, track, seed=seed, seconds=seconds)


def label(drive: Drive, sweep: LidarCones, gate_m: float = 0.5) -> np.ndarray:
    """The true cone (index into the track's cones) of each detection of ``sweep`` (N,), -1 for
    a detection with no true cone within ``gate_m`` of it (at the true pose of its time)."""
    out = np.full(len(sweep.cones), -1, np.int64)
    for i, c in enumerate(sweep.cones):
        x, y, yaw = drive.truth.at(c.timestamp_s)
        rel = world_to_vehicle(drive.cones_xy_m, x, y, yaw)
        d = np.hypot(rel[:, 0] - c.x_m, rel[:, 1] - c.y_m)
        j = int(np.argmin(d))
        if d[j] <= gate_m:
            out[i] = j
    return out


def with_lidar_errors(drive: Drive, miss: float, false_fraction: float, seed: int
                      ) -> tuple[Drive, list[np.ndarray]]:
    """``drive`` with each LiDAR detection missed with probability ``miss`` and false cones
    added (Poisson, ``false_fraction`` of the sweep's detections; uniform in range and
    bearing ahead, 2 to 15 m, with cone-like sizes); returns it with each sweep's labels
    (:func:`label`; -1 for the false ones)."""
    rng = np.random.default_rng(seed)
    arrivals: list[tuple[float, Reading]] = []
    labels: list[np.ndarray] = []
    for t, r in drive.arrivals:
        if isinstance(r, LidarCones):
            truth = label(drive, r)
            keep = rng.random(len(r.cones)) >= miss
            cones = [c for c, k in zip(r.cones, keep, strict=True) if k]
            n_false = int(rng.poisson(false_fraction * max(len(r.cones), 1)))
            for _ in range(n_false):
                rho = rng.uniform(2.0, 15.0)
                phi = rng.uniform(-0.5, 0.5) * math.pi
                cones.append(ConeDetection(r.timestamp_s, rho * math.cos(phi),
                                           rho * math.sin(phi),
                                           height_m=float(rng.uniform(0.25, 0.4)),
                                           width_m=float(rng.uniform(0.18, 0.3))))
            r = dataclasses.replace(r, cones=tuple(cones))
            labels.append(np.concatenate([truth[keep], np.full(n_false, -1, np.int64)]))
        arrivals.append((t, r))
    return dataclasses.replace(drive, arrivals=arrivals), labels
