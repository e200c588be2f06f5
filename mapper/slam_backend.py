"""The ``slam`` mapping backend: seed 000's EKF SLAM maps and localises during the exploration.

The UKF does not run meanwhile. The loop closes by the SLAM's controlled loop closure at the
big orange cones (:mod:`mapper.slam.loop_closure`); at the freeze the UKF is seeded from the
SLAM: its pose, velocities, IMU biases and their covariances, and with the SLAM's own map the
map's error covariance and its cross-covariance with the pose as consider states.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np

from common.car import CarConfig
from common.conventions import WorldFrame
from common.messages import (
    ConeDetection,
    ConeMap,
    GpsFix,
    ImuSample,
    PoseEstimate,
    SteeringAngle,
    WheelSpeeds,
)
from mapper.backend import FloatArray, Lagged, SweepResult
from mapper.config import MapperConfig
from mapper.slam.ekf_slam import EkfSlam
from mapper.ukf_localiser import UkfLocaliser
from mapper.ukf_state import N_BIAS, N_STATE


class SlamBackend:
    """EKF SLAM behind the Mapper's backend protocol (:class:`mapper.backend.MappingBackend`);
    ``count(sensor, outcome)`` counts in the Mapper's statistics."""

    name = "slam"
    owns_map_errors = True

    def __init__(self, config: MapperConfig, car: CarConfig, ukf: UkfLocaliser,
                 count: Callable[[str, str], None]) -> None:
        self.config = config
        self.slam = EkfSlam(config, car)
        self.ukf = ukf
        self._count = count
        self.refines_gnss_frame = config.ukf.gnss_frame_refine

    def predict(self, imu: ImuSample) -> None:
        self.slam.predict(imu)

    def update_odometry(self, wheels: WheelSpeeds, steer: SteeringAngle | None) -> None:
        self.slam.update_odometry(wheels, steer)
        if self.config.slam.use_odometry:
            self._count("odometry", "applied")

    def update_gnss(self, xy_world_m: FloatArray, fix: GpsFix, frame: WorldFrame) -> None:
        self.slam.update_gps_xy(xy_world_m, np.eye(2) * self.config.slam.gps_sigma_m**2,
                                fix.timestamp_s)

    def update_lidar(self, cones: Sequence[ConeDetection], timestamp_s: float,
                     odometer_m: float) -> SweepResult:
        self.slam.update_cones(cones, timestamp_s)
        return SweepResult(map_changed=True, loop_closed=self.slam.try_close_loop())

    def add_colours(self, cones: Sequence[ConeDetection]) -> bool:
        self.slam.add_colour_votes(cones, self.slam.pose())
        return True

    def pose(self) -> PoseEstimate:
        return self.slam.pose()

    def lagged(self, now_s: float) -> Lagged:
        p = self.slam.pose()
        state = np.array([p.x_m, p.y_m, p.yaw_rad, p.vx_mps, p.vy_mps, p.yaw_rate_radps])
        return Lagged(state, p.covariance, p.timestamp_s, self.slam.imu_bias, False)

    def cone_map(self) -> ConeMap:
        return self.slam.cone_map()

    def stats(self) -> dict[str, dict[str, int]]:
        return {"slam": dict(self.slam.stats)}

    def hand_over(self, cone_map: ConeMap, own_map: bool) -> ConeMap:
        """Seed the UKF from the SLAM (pose, velocities, IMU biases, their covariances).

        With ``own_map`` (the SLAM's map is frozen) the UKF takes the SLAM's joint covariance:
        its vehicle block mapped to the UKF's states, the landmark block as the map's error
        covariance and the vehicle-landmark block as their cross-covariance (the map's errors
        are consider states of the UKF: :meth:`UkfLocaliser.set_map`), and localises on that
        map; else the map is set by the caller."""
        slam = self.slam
        ukf = self.ukf
        ukf.set_map(None)
        ukf.reset(slam.pose())
        p = slam.pose()
        ukf.x[3:6] = np.array([p.vx_mps, p.vy_mps, p.yaw_rate_radps])
        ukf.t_s = slam.t_s
        v = slam.vehicle_dim
        if v > 5:
            # The SLAM estimated the IMU biases on the way (the car may never have stood
            # still for the UKF's static calibration): the UKF goes on with them.
            ukf.set_imu_bias(slam.imu_bias, np.array(slam.P[5:v, 5:v]))
        else:
            ukf.calibrating = False
        if not own_map:
            return cone_map
        P = np.array(slam.P)
        T = slam_to_ukf_jacobian(ukf.x, v, ukf.n)
        pv = T @ P[:v, :v] @ T.T
        # The UKF's yaw-rate state is the last gyro sample less the bias: the gyro's noise.
        pv[5, 5] += self.config.ukf.gyro_sigma_radps ** 2
        keep = [ukf.ih] if ukf.ih is not None else []
        if v == 5 or not ukf.nb:
            # Bias states in one filter only: they keep what set_imu_bias / reset gave them.
            keep += list(range(6, 6 + ukf.nb))
        if keep:
            kept = ukf.P[np.ix_(keep, keep)]
            pv[keep, :] = 0.0
            pv[:, keep] = 0.0
            pv[np.ix_(keep, keep)] = kept
        ukf.reset(ukf.pose(), covariance=0.5 * (pv + pv.T))
        ukf.t_s = slam.t_s
        ukf.set_map(slam.cone_map(), P[v:, v:], T @ P[:v, v:])
        assert ukf.consider_map is not None
        return ukf.consider_map


def slam_to_ukf_jacobian(ukf_x: np.ndarray, slam_dim: int, ukf_dim: int) -> np.ndarray:
    """(ukf_dim, slam_dim) Jacobian of the UKF's state (x, y, yaw, vx, vy, yaw rate[, gyro,
    accel x, accel y bias]) with respect to the SLAM's (x, y, yaw, world vx, world vy[, the same
    biases]) at the UKF's state ``ukf_x``: body velocities are the world ones rotated by -yaw;
    the yaw rate is the gyro less its bias."""
    T = np.zeros((ukf_dim, slam_dim))
    T[0, 0] = T[1, 1] = T[2, 2] = 1.0
    yaw, vx, vy = float(ukf_x[2]), float(ukf_x[3]), float(ukf_x[4])
    c, s = math.cos(yaw), math.sin(yaw)
    T[3, 3], T[3, 4], T[3, 2] = c, s, vy
    T[4, 3], T[4, 4], T[4, 2] = -s, c, -vx
    if slam_dim > 5 and ukf_dim >= N_STATE + N_BIAS:
        T[5, 5] = -1.0
        T[6, 5] = T[7, 6] = T[8, 7] = 1.0
    return T
