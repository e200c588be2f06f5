"""The car's geometry and limits: the one configuration section every tier reads.

The vehicle origin is the rear-axle centre on the ground (``common/conventions.py``); every
position below is measured from it along the vehicle's x axis (m).
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(slots=True)
class CarConfig:
    """The car's geometry and limits (the default car of the issues; SI units)."""

    name: str = "default"
    wheelbase_m: float = 1.53
    track_width_m: float = 1.2
    length_m: float = 2.9
    width_m: float = 1.4
    rear_overhang_m: float = 0.65
    """Distance from the rear axle (the vehicle origin) back to the rear of the car."""
    cg_to_front_axle_m: float = 0.84
    mass_kg: float = 230.0
    yaw_inertia_kgm2: float = 120.0
    wheel_radius_m: float = 0.2286
    max_lateral_accel_mps2: float = 1.5 * 9.81
    max_drive_accel_mps2: float = 8.0
    max_brake_decel_mps2: float = 12.0
    max_steer_rad: float = 0.52
    """Road-wheel steering limit: 30 degrees turn the rear axle on 2.66 m, which takes the
    rules' tightest hairpin (9 m outer diameter) with the front corner 0.2 m inside it."""
    max_steer_rate_radps: float = 1.5
    steer_lag_s: float = 0.05
    top_speed_mps: float = 25.0
    lidar_x_m: float = 1.9
    """LiDAR position ahead of the vehicle origin (m): seed 000 mounts it low at the front."""
    lidar_z_m: float = 0.3
    imu_x_m: float = 0.7
    imu_roll_rad: float = 0.0
    imu_pitch_rad: float = 0.0
    imu_yaw_rad: float = 0.0
    """The IMU's mounting rotation against the vehicle frame (rad; about x, then y, then z:
    ``common.conventions.mount_rotation``); the Mapper turns its samples into the vehicle frame.
    All zero (the default): mounted aligned, samples taken as they are."""
    camera_x_m: float = 0.9
    camera_z_m: float = 1.0
