"""EKF SLAM alone over a simulated drive (support.sim_drive): what the filter makes of it.

The readings go to :class:`~mapper.slam.ekf_slam.EkfSlam` in the order they were made: IMU
samples predict, wheel speeds update the odometry, GNSS fixes update the position (in the
simulated world's own frame, known here, at the SLAM's GPS sigma), LiDAR sweeps (through the
Mapper's object filter) update the map, camera cones vote colours. The pose is recorded after
every sweep with the truth at its time.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from common.car import CarConfig
from common.messages import CameraCones, GpsFix, ImuSample, LidarCones, WheelSpeeds
from mapper.config import MapperConfig
from mapper.evaluation import (
    evaluate_map,
    nees,
    nees_fraction_in_band,
    pose_error_vectors,
    pose_errors,
)
from mapper.object_filter import ObjectFilter
from mapper.slam.ekf_slam import EkfSlam
from support.sim_drive import Drive


@dataclass
class SlamRun:
    """What :func:`run_slam` measured: the filter at the end, poses (T, 3) after each sweep with
    their covariances (T, 3, 3) and the truth, map and pose metrics, the pose NEES."""

    slam: EkfSlam
    times_s: np.ndarray
    est_pose: np.ndarray
    true_pose: np.ndarray
    pose_cov: np.ndarray
    est_velocity: np.ndarray
    """(T, 2) vehicle-frame vx, vy (m/s) after each sweep."""
    true_velocity: np.ndarray
    map_metrics: dict[str, Any] = field(default_factory=dict)
    pose_metrics: dict[str, float] = field(default_factory=dict)
    nees_values: np.ndarray = field(default_factory=lambda: np.zeros(0))
    nees_in_band: float = math.nan


def run_slam(drive: Drive, config: MapperConfig | None = None,
             car: CarConfig | None = None) -> SlamRun:
    """Feed ``drive`` to a fresh :class:`EkfSlam`; see the module docstring."""
    cfg = config or MapperConfig()
    car = car or CarConfig()
    slam = EkfSlam(cfg, car)
    object_filter = ObjectFilter(cfg.object_filter)
    gps_cov = np.eye(2) * cfg.slam.gps_sigma_m ** 2
    times, est, covs, vel = [], [], [], []
    for r in drive.readings():
        if isinstance(r, ImuSample):
            slam.predict(r)
        elif isinstance(r, WheelSpeeds):
            slam.update_odometry(r, None)
        elif isinstance(r, GpsFix):
            xy = drive.frame.geodetic_to_world(r.lat_deg, r.lon_deg).reshape(2)
            slam.update_gps_xy(xy, gps_cov, r.timestamp_s)
        elif isinstance(r, LidarCones):
            slam.update_cones(object_filter.filter(r.cones), r.timestamp_s)
            pose = slam.pose()
            times.append(r.timestamp_s)
            est.append((pose.x_m, pose.y_m, pose.yaw_rad))
            covs.append(pose.covariance)
            vel.append((pose.vx_mps, pose.vy_mps))
        elif isinstance(r, CameraCones):
            slam.add_colour_votes(r.cones)
    t_arr = np.array(times)
    truth = np.array([drive.truth.at(t) for t in t_arr]).reshape(-1, 3)
    est_arr, cov_arr = np.array(est).reshape(-1, 3), np.array(covs).reshape(-1, 3, 3)
    tr = drive.truth
    true_vel = np.stack([np.interp(t_arr, tr.t_s, tr.vx_mps), np.interp(t_arr, tr.t_s, tr.vy_mps)],
                        axis=1)
    run = SlamRun(slam, t_arr, est_arr, truth, cov_arr, np.array(vel).reshape(-1, 2), true_vel)
    run.map_metrics = evaluate_map(slam.cone_map(), drive.cones_xy_m, drive.cone_colours)
    run.pose_metrics = pose_errors(est_arr, truth)
    settled = t_arr >= 1.0  # the first second is the filter's own start (pose known exactly)
    run.nees_values = nees(pose_error_vectors(est_arr, truth)[settled],
                           cov_arr[settled] + np.eye(3) * 1e-12)
    run.nees_in_band = nees_fraction_in_band(run.nees_values, 3)
    return run
