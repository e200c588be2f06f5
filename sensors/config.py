"""Configuration of the Sensor Manager: one section per receiver."""

from __future__ import annotations

from dataclasses import dataclass, field


@dataclass(slots=True)
class GpsConfig:
    """Serial NMEA GPS: any pyserial port name or URL."""

    enabled: bool = True
    port: str = "/dev/ttyACM0"
    baudrate: int = 115200
    timeout_s: float = 0.5
    """A source silent for longer than this is stale."""
    read_timeout_s: float = 0.05


@dataclass(slots=True)
class ImuConfig:
    """Serial IMU speaking the protocol of sensors/imu_protocol.py."""

    enabled: bool = True
    port: str = "/dev/ttyUSB0"
    baudrate: int = 921600
    timeout_s: float = 0.1
    read_timeout_s: float = 0.05


@dataclass(slots=True)
class CanConfig:
    """A python-can bus, decoded with the car's DBC file."""

    enabled: bool = True
    interface: str = "socketcan"
    channel: str = "can0"
    bitrate: int = 500000
    dbc: str = ""
    """Path of the DBC file; empty for the car.dbc shipped with the project."""
    timeout_s: float = 0.1
    read_timeout_s: float = 0.05
    res_timeout_s: float = 0.5
    """No RES_STATE frame for longer than this makes the "res" source stale (an emergency)."""
    slcan_open_delay_s: float = 0.0
    """slcan only: wait after opening the tty (Arduino-based adapters reset on open: 2 s)."""


@dataclass(slots=True)
class LidarConfig:
    """Velodyne VLP-16 data packets over UDP."""

    enabled: bool = True
    host: str = "0.0.0.0"
    port: int = 2368
    timeout_s: float = 0.3
    read_timeout_s: float = 0.05


@dataclass(slots=True)
class CameraConfig:
    """Camera cone detections as protobuf datagrams over UDP."""

    enabled: bool = True
    host: str = "0.0.0.0"
    port: int = 5600
    timeout_s: float = 0.3
    read_timeout_s: float = 0.05


@dataclass(slots=True)
class SensorsConfig:
    """Every receiver the Sensor Manager builds."""

    gps: GpsConfig = field(default_factory=GpsConfig)
    imu: ImuConfig = field(default_factory=ImuConfig)
    can: CanConfig = field(default_factory=CanConfig)
    lidar: LidarConfig = field(default_factory=LidarConfig)
    camera: CameraConfig = field(default_factory=CameraConfig)
    queue_length: int = 4096
    stop_timeout_s: float = 1.0
    reconnect_min_s: float = 0.05
    """First wait before reopening a vanished port / bus-off bus; doubles up to reconnect_max_s."""
    reconnect_max_s: float = 1.0
    rate_window_s: float = 2.0
    """Window (s) over which health() reports each source's rate."""
