"""The one small protocol between the Mapper and whatever estimates the car's state.

While the car explores, a mapping backend maps the cones and gives the pose: EKF SLAM
(:mod:`mapper.slam_backend`) or seed 002's time smoother beside the UKF
(:mod:`mapper.smoother_backend`); each closes the loop by its own rule. Once the loop is closed
the map is frozen and the UKF localises on it (:mod:`mapper.map_localiser`). All of them take
the readings the same way (:class:`Estimator`); the Mapper only chooses which one is active.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

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
from mapper import ukf_gnss
from mapper.motion import compensate_motion
from mapper.ukf_localiser import UkfLocaliser

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class Lagged:
    """The estimator's state at its own (lagged) time, to be predicted forward to now.

    ``state`` (6,): x_m, y_m, yaw_rad, vx_mps, vy_mps (vehicle frame), yaw_rate_radps;
    ``covariance`` (3, 3) over x, y, yaw; ``t_s`` its time (s); the IMU biases it estimates
    (gyro z rad/s, accelerometer x, y m/s^2); ``calibrating``: standing still for them.
    """

    state: FloatArray
    covariance: FloatArray
    t_s: float
    imu_bias: tuple[float, float, float]
    calibrating: bool


@dataclass(frozen=True)
class SweepResult:
    """What a LiDAR sweep did: whether the map changed and whether the loop closed now."""

    map_changed: bool
    loop_closed: bool = False


class Estimator(Protocol):
    """Takes the readings in time order and gives the (lagged) pose and the map."""

    def predict(self, imu: ImuSample) -> None:
        """Propagate with one IMU sample."""

    def update_odometry(self, wheels: WheelSpeeds, steer: SteeringAngle | None) -> None:
        """Wheel speeds (and the latest steering angle)."""

    def update_gnss(self, xy_world_m: FloatArray, fix: GpsFix, frame: WorldFrame) -> None:
        """A fix as a world-frame position (2,) (m), with its course and speed."""

    def update_lidar(self, cones: Sequence[ConeDetection], timestamp_s: float,
                     odometer_m: float) -> SweepResult:
        """One sweep of filtered cones (vehicle frame), after ``odometer_m`` of travel."""

    def add_colours(self, cones: Sequence[ConeDetection]) -> bool:
        """Camera cones with a colour; True when the map's colours may have changed."""

    def pose(self) -> PoseEstimate:
        """The pose at the estimator's own time (for the GNSS frame estimate)."""

    def lagged(self, now_s: float) -> Lagged:
        """The state to predict forward to now."""

    def cone_map(self) -> ConeMap:
        """The map as it is."""


class MappingBackend(Estimator, Protocol):
    """An estimator that maps while the car explores, with its own loop closure rule."""

    name: str
    """``slam`` or ``smoother`` (``MapState.backend``)."""
    refines_gnss_frame: bool
    """Feed the GNSS frame estimator with this backend's pose all along (not only until the
    frame is found), for a refinement at the freeze."""
    owns_map_errors: bool
    """At the freeze the backend hands the UKF its own map's error covariance (consider
    states); else the Mapper sets the map with its cones' own covariances."""

    def hand_over(self, cone_map: ConeMap, own_map: bool) -> ConeMap:
        """The map freezes: seed the UKF from what the backend knows; returns the map the UKF
        localises on (``own_map``: the backend's own, not a surveyed one)."""

    def stats(self) -> dict[str, dict[str, int]]:
        """The backend's own counters by name (merged into the Mapper's ``stats``)."""


class UkfInputs:
    """IMU, wheels and GNSS into the UKF of seed 001, as the smoother backend and the
    localisation on the frozen map both take them."""

    def __init__(self, ukf: UkfLocaliser) -> None:
        self.ukf = ukf

    def predict(self, imu: ImuSample) -> None:
        self.ukf.predict(imu)

    def update_odometry(self, wheels: WheelSpeeds, steer: SteeringAngle | None) -> None:
        self.ukf.catch_up(wheels.timestamp_s)
        self.ukf.update_odometry(wheels, steer)

    def update_gnss(self, xy_world_m: FloatArray, fix: GpsFix, frame: WorldFrame) -> None:
        self.ukf.catch_up(fix.timestamp_s)
        cov = ukf_gnss.receiver_covariance(self.ukf.config, fix, frame.start_yaw_enu_rad)
        self.ukf.update_gnss_position(xy_world_m, cov)
        course = (frame.enu_yaw_to_world_yaw(fix.course_rad)
                  if math.isfinite(fix.course_rad) else math.nan)
        self.ukf.update_gnss_velocity(fix.speed_mps, course)

    def pose(self) -> PoseEstimate:
        return self.ukf.pose()

    def lagged(self, now_s: float) -> Lagged:
        ukf = self.ukf
        return Lagged(ukf.x, ukf.P[:3, :3], ukf.t_s if ukf.t_s is not None else now_s,
                      ukf.imu_bias, ukf.calibrating)

    def compensated(self, cones: Sequence[ConeDetection], timestamp_s: float) -> FloatArray:
        """The detections (N, 2) moved to the UKF's own time (its last IMU sample, up to one
        IMU period before the sweep's stamp), where they are compared with its pose. After
        an IMU silent for longer, the UKF is first caught up to the sweep
        (:meth:`UkfLocaliser.catch_up`)."""
        self.ukf.catch_up(timestamp_s)
        x = self.ukf.x
        t_ref = self.ukf.t_s if self.ukf.t_s is not None else timestamp_s
        return compensate_motion(cones, t_ref, float(x[3]), float(x[4]), float(x[5]))
