"""Configuration of the simulator: track, seed, physics rate, faults and sensor-model noise.

Every sensor model reads its own sub-section (``config.sim.gps``, ``.imu``, ``.can``, ``.lidar``,
``.camera``). Probabilities are per emitted unit (sentence, packet, frame). A model with
``enabled = false`` emits nothing.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Protocol

from common.car import CarConfig
from sensors.config import SensorsConfig


@dataclass(slots=True)
class GpsSimConfig:
    """Simulated NMEA GPS (GGA, RMC, VTG, GSA) about the geodetic origin of :class:`SimConfig`."""

    enabled: bool = True
    rate_hz: float = 10.0
    sigma_m: float = 2.5
    """White horizontal position noise per axis (m)."""
    bias_sigma_m: float = 1.0
    """Stationary standard deviation of the slowly wandering position bias per axis (m)."""
    bias_tau_s: float = 60.0
    """Correlation time of the bias (first-order Gauss-Markov, s)."""
    altitude_sigma_m: float = 4.0
    speed_sigma_mps: float = 0.1
    course_sigma_rad: float = 0.05
    satellites: int = 10
    hdop: float = 1.0
    dropout_prob: float = 0.0
    """Probability that a whole epoch (all sentences of one fix) is not sent."""
    corrupt_prob: float = 0.0
    """Probability that a sentence gets a wrong checksum or a flipped byte."""


@dataclass(slots=True)
class ImuSimConfig:
    """Simulated serial IMU at the car's imu_x_m, gravity in +z."""

    enabled: bool = True
    rate_hz: float = 200.0
    accel_sigma_mps2: float = 0.05
    gyro_sigma_radps: float = 0.002
    accel_bias_sigma_mps2: float = 0.05
    """Standard deviation of the constant per-run accelerometer bias per axis (m/s^2)."""
    gyro_bias_sigma_radps: float = 0.002
    """Standard deviation of the constant per-run gyro bias per axis (rad/s)."""
    dropout_prob: float = 0.0
    corrupt_prob: float = 0.0


@dataclass(slots=True)
class CanSimConfig:
    """Simulated CAN bus: wheel speeds and steering angle, RES state."""

    enabled: bool = True
    wheel_rate_hz: float = 100.0
    steering_rate_hz: float = 100.0
    res_rate_hz: float = 10.0
    wheel_speed_sigma_mps: float = 0.03
    wheel_slip_sigma: float = 0.01
    """Relative slip noise of each wheel speed (fraction of the speed)."""
    steering_sigma_rad: float = 0.002
    dropout_prob: float = 0.0
    corrupt_prob: float = 0.0


@dataclass(slots=True)
class LidarSimConfig:
    """Simulated Velodyne VLP-16 from ray-casting cones and a flat ground."""

    enabled: bool = True
    rpm: float = 600.0
    """Rotation speed (600 rpm = 10 Hz, about 0.2 deg azimuth steps)."""
    range_sigma_m: float = 0.02
    max_range_m: float = 60.0
    ground: bool = True
    """Ray-cast the flat ground as well as the cones."""
    dropout_prob: float = 0.0
    """Probability that a return is missing."""
    packet_loss_prob: float = 0.0
    """Probability that a whole UDP packet is not sent."""


@dataclass(slots=True)
class CameraSimConfig:
    """Simulated camera cone detections (project protobuf over UDP)."""

    enabled: bool = True
    rate_hz: float = 20.0
    fov_rad: float = 1.5707963267948966
    """Horizontal field of view (90 deg)."""
    max_range_m: float = 20.0
    position_sigma_m: float = 0.05
    """Position noise at zero range (m); grows with range_sigma_per_m."""
    range_sigma_per_m: float = 0.02
    """Additional position noise per metre of range (m/m)."""
    miss_prob: float = 0.05
    false_positive_rate: float = 0.1
    """Mean number of false detections per frame."""
    colour_error_prob: float = 0.02
    latency_s: float = 0.05


@dataclass(slots=True)
class SimConfig:
    """A closed-loop simulation run."""

    track: str = "default"
    """"default", "gen:SEED" or a path to an EUFS .csv / AMZ FSSIM .yaml track file."""
    seed: int = 1
    physics_rate_hz: float = 200.0
    origin_lat_deg: float = 49.3269
    origin_lon_deg: float = 8.5654
    origin_alt_m: float = 100.0
    start_heading_enu_rad: float = 0.0
    """The simulated world frame's heading in ENU (rad, CCW from east): where the car faces."""
    driver_speed_mps: float = 7.0
    """Target speed of the scripted (exploration) driver."""
    driver_steer_noise_rad: float = 0.01
    """Standard deviation of the scripted driver's smoothed steering noise."""
    faults: list[str] = field(default_factory=list)
    """Faults to inject, each "KIND@T[:DURATION]" (see simulator/faults.py)."""
    mission_select: str = "run"
    """What the simulated car sends in ``MISSION_SELECT`` (10 Hz): ``run`` the run's mission
    (``--mission``), ``missing`` no frame at all, a mission's name (``none``, ``trackdrive``,
    ``autocross``, ``acceleration``, ``skidpad``, ``unknown``) or a wire value 0..15."""
    gps: GpsSimConfig = field(default_factory=GpsSimConfig)
    imu: ImuSimConfig = field(default_factory=ImuSimConfig)
    can: CanSimConfig = field(default_factory=CanSimConfig)
    lidar: LidarSimConfig = field(default_factory=LidarSimConfig)
    camera: CameraSimConfig = field(default_factory=CameraSimConfig)


class WorldConfig(Protocol):
    """What the simulated world reads of the application's configuration: its own section, the
    car's, and the sensors' (the CAN database its bus speaks). Main's configuration has them."""

    @property
    def sim(self) -> SimConfig: ...

    @property
    def car(self) -> CarConfig: ...

    @property
    def sensors(self) -> SensorsConfig: ...
