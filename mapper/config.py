"""Configuration of the Mapper: backend choice and each estimator's parameters."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal


@dataclass(slots=True)
class SmootherConfig:
    """Seed 002, table 2: the time smoother's optimal parameters."""

    size_ratio_x: float = 0.7
    size_ratio_y: float = 0.7
    match_distance_m: float = 1.5
    conf_limit: float = 20.0
    confidence_decay: float = 1.0
    match_conf: float = 2.0
    initial_conf: float = 2.0


@dataclass(slots=True)
class SlamConfig:
    """Seed 000, section 5.3: EKF SLAM with controlled loop closure (see mapper/ekf_slam.py)."""

    gyro_noise_density_radps_rthz: float = 2.0e-3
    """Gyro white noise (rad/s/sqrt(Hz)), with model error; Q = G diag(sigma^2 / T) G^T."""
    accel_noise_density_mps2_rthz: float = 0.05
    """Accelerometer white noise (m/s^2/sqrt(Hz)), with pitch/roll leakage and vibration."""
    heading_mode: Literal["midpoint", "seed"] = "midpoint"
    """Eq. 5.2: 'seed' uses alpha = theta + T^2/2 * yaw rate literally; 'midpoint' uses T/2."""
    imu_lever_arm: bool = True
    """Move the IMU's specific force from car.imu_x_m to the rear axle (centripetal, tangential)."""
    max_predict_dt_s: float = 0.1
    initial_position_sigma_m: float = 1.0e-3
    initial_yaw_sigma_rad: float = 1.0e-3
    initial_velocity_sigma_mps: float = 0.2
    lidar_range_sigma_m: float = 0.02
    lidar_bearing_sigma_rad: float = 0.002
    measurement_sigma_floor_m: float = 0.01
    """Seed 5.3.5: no measurement noise below this (keeps S well conditioned)."""
    motion_compensation_sigma_mps: float = 0.2
    """Velocity uncertainty when a detection is moved to its sweep's timestamp (adds noise)."""
    max_range_m: float = 25.0
    gate_probability: float = 0.997
    """Chi-square gate (2 dof) for associating a detection with a landmark."""
    new_landmark_probability: float = 0.99999
    """A detection inside this gate of any landmark is ambiguous: never a new landmark."""
    new_landmark_min_distance_m: float = 1.0
    preliminary_gate_m: float = 0.5
    """Seed 5.3.3: a candidate enters the filter when seen again this close in the next sweep."""
    unseen_travel_m: float = 25.0
    """Seed 5.3.2: no association with landmarks not seen for this travel distance."""
    associate_all_after_closure: bool = True
    min_lap_distance_m: float = 80.0
    """Loop closure is tried only after this travel distance."""
    big_cone_search_m: float = 6.0
    """Largest drift (m) at which old and new big orange cones are still paired."""
    big_cone_pattern_tolerance_m: float = 0.6
    min_big_cone_pairs: int = 2
    merge_distance_m: float = 1.2
    merge_gate_probability: float = 0.9999
    same_point_sigma_m: float = 1.0e-3
    """The 'zero-noise' same-point measurement's floor (m): seed 5.3.2 uses none."""
    wheel_speed_sigma_mps: float = 0.05
    lateral_velocity_sigma_mps: float = 0.05
    """Non-holonomic pseudo-measurement: the rear axle does not slide sideways."""
    use_odometry: bool = True
    use_gps: bool = True
    gps_gate_probability: float = 0.9999
    colour_gate_m: float = 1.0
    """Camera cones vote for the nearest landmark within this distance (world frame)."""


@dataclass(slots=True)
class MapperConfig:
    """Which backend maps, and its parameters."""

    backend: Literal["slam", "smoother"] = "slam"
    smoother: SmootherConfig = field(default_factory=SmootherConfig)
    slam: SlamConfig = field(default_factory=SlamConfig)
