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
    read_timeout_s: float = 0.02
    """Longest blocking read (s): a sensor fallen silent is noticed at most this late."""


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
    udp_port: int = 43113
    """udp_multicast only: the bus's UDP port (python-can's default 43113)."""


@dataclass(slots=True)
class DetectorConfig:
    """LiDAR cone detection (seed 000, section 4.2); see sensors/cone_detector.py."""

    min_range_m: float = 1.0
    """Returns closer to the sensor than this (horizontally) are dropped (m)."""
    max_range_m: float = 15.0
    """Preliminary filter: surfaces farther than this are dropped (m)."""
    fov_half_deg: float = 120.0
    """Usable field of view either side of straight ahead (deg); the rest sees the car."""
    car_margin_m: float = 0.1
    """Returns inside the car's footprint grown by this margin are dropped (m)."""
    ground_clearance_m: float = 0.05
    """Returns lower than this above the ground plane are ground (m)."""
    max_point_height_m: float = 0.7
    """Returns higher than this above the ground cannot be cone surface (m)."""
    surface_range_jump_m: float = 0.15
    """A range step larger than this between successive returns of a ring splits surfaces (m)."""
    surface_max_gap_deg: float = 0.65
    """An azimuth gap larger than this between successive returns of a ring splits (deg)."""
    max_surface_width_m: float = 0.40
    """Preliminary filter: surfaces wider than this are not part of a cone (m)."""
    min_surface_points: int = 2
    merge_distance_m: float = 0.3
    """Surfaces whose x-y midpoints are closer than this form one preliminary cone (m)."""
    cluster_radius_m: float = 0.9
    cluster_max_cones: int = 3
    """Cluster filter: a preliminary cone with more than this many (itself included) within
    cluster_radius_m goes. Seed 000 says "more than two"; 3, because round the tightest
    hairpins cones stand 0.7 m apart along a boundary (a community layout's 1.7 m inner ring),
    which puts three within 0.9 m; grass and bushes break into many more surfaces."""
    min_layers: int = 2
    min_layer_fraction: float = 0.0
    """A preliminary cone must show on at least this fraction (rounded down) of the rings that
    cross a small cone's height at its range: rain, spray and dust show on one or two rings, a
    cone on most of them (0: no check)."""
    single_layer_beyond_m: float = 4.0
    """Beyond this range one layer is accepted when the ring geometry allows only one (m)."""
    min_points: int = 3
    small_height_m: float = 0.30
    large_height_m: float = 0.50
    height_tolerance_m: float = 0.05
    """A top measured above large_height_m plus this is not a cone (m)."""
    size_from_ring_counts: bool = True
    """A cone whose top is below ``small_height_m`` is still large when its returns per ring
    fit a large cone better (a sparse sensor's rings miss the top beyond a few metres); off
    for a sensor whose many beams find every top."""
    min_top_m: float = 0.0
    """A preliminary cone whose highest return is lower than this above the ground is a bump
    of the ground, not a cone (m)."""
    max_float_m: float = 0.0
    """A preliminary cone whose lowest return is higher than this above the lowest ring that
    can hit a cone at its range floats (raindrops, spray, an overhanging branch): not a cone
    (m); 0: no check."""
    tall_clearance_m: float = 0.0
    """A preliminary cone with a return higher than ``max_point_height_m`` (a leg, a pole, a
    barrier) within this horizontal distance of its centre is not a cone (m); 0: no check."""
    clear_inner_m: float = 0.3
    clear_outer_m: float = 0.0
    clear_max_returns: int = 2
    """A preliminary cone with more than ``clear_max_returns`` returns above the ground at
    ``clear_inner_m`` .. ``clear_outer_m`` from its centre stands in clutter (a bush, a kerb,
    a wall's foot), not on open ground as a cone does (m); ``clear_outer_m`` 0: no check."""
    ground: str = "flat"
    """``flat``: the ground is the plane ``car.lidar_z_m`` below the sensor (the simulator's
    world); ``estimated``: a smooth surface fitted to the sweep's lowest returns, for real
    ground that slopes under a sensor whose height is not known exactly."""
    ground_cell_m: float = 1.0
    """``estimated`` ground: the size of the cells whose lowest return samples the ground (m)."""
    ground_max_residual_m: float = 0.06
    """``estimated`` ground: a cell whose lowest return is farther than this from the fitted
    surface (a cell filled by an object) is left out of the fit (m)."""
    centre_push_fraction: float = 1.0
    """How far the centroid of a cone's returns is pushed back along the line of sight, as a
    fraction of pi/4 of the cone's radius at each return's height (1: the centre of a cone
    whose near half is sampled evenly; 0: the centroid of the returns)."""


@dataclass(slots=True)
class LidarConfig:
    """Spinning LiDAR data packets over UDP (the VLP-16 unless ``model`` says another)."""

    enabled: bool = True
    model: str = "vlp16"
    """Which sensor sends the packets (sensors/lidar_models.py): ``vlp16``, ``hdl32e`` (Velodyne,
    port 2368) or ``os1-64`` (Ouster OS1, legacy packets, port 7502, needs ``meta_file``);
    packets of another model are refused and counted as ``wrong_model``."""
    meta_file: str = ""
    """An Ouster's metadata JSON file (beam angles, mode); only for ``os1-64``."""
    host: str = "0.0.0.0"
    port: int = 2368
    timeout_s: float = 0.3
    read_timeout_s: float = 0.05
    cut_azimuth_deg: float = 180.0
    """Sweeps are cut where the azimuth passes this (deg, clockwise from ahead: 180 = behind)."""
    detector: DetectorConfig = field(default_factory=DetectorConfig)


@dataclass(slots=True)
class CameraConfig:
    """Camera cone detections as protobuf datagrams over UDP."""

    enabled: bool = True
    host: str = "0.0.0.0"
    port: int = 5600
    timeout_s: float = 0.3
    read_timeout_s: float = 0.05
    clock_offset_s: float = 0.0
    """Added to the camera computer's image times to put them on this computer's clock (s):
    0 when both are synchronised (chrony / PTP)."""
    max_latency_s: float = 0.25
    """An image time (plus the offset) more than this before its arrival, or after it, means
    the two clocks disagree: the frame is then stamped on arrival less ``assumed_latency_s``
    (counted as ``restamped`` and logged) rather than left to be dropped as stale (s)."""
    assumed_latency_s: float = 0.1
    """Image-to-arrival latency of the camera pipeline assumed when restamping (s)."""


def _real_cloud_detector() -> DetectorConfig:
    """The detector's settings for real point clouds (``detect``): the ground estimated, a
    return on its own may be a cone's surface (a 40-beam sensor hits a cone at 10 m once per
    beam), and clutter rejected by shape (tall neighbours, returns round it). With many beams
    a cone's top is found, so a top above 0.415 m (halfway between a small cone's 0.325 m and a
    large one's 0.505 m) makes a large cone."""
    return DetectorConfig(ground="estimated", min_surface_points=1, min_layers=1, min_points=2,
                          min_top_m=0.12, tall_clearance_m=0.5, centre_push_fraction=0.0,
                          fov_half_deg=180.0, max_range_m=13.0, small_height_m=0.415,
                          size_from_ring_counts=False, clear_outer_m=0.6,
                          min_layer_fraction=0.3, max_float_m=0.15, clear_max_returns=3)


@dataclass(slots=True)
class SceneDetectConfig:
    """``python main.py detect``: cone detection in recorded point clouds (a scene folder or a
    capture), with the car's own body cut out by a footprint in the LiDAR frame."""

    lidar_model: str = ""
    """The sensor that recorded the clouds (a name of sensors/lidar_models.py); empty: the
    car's ``sensors.lidar.model``. ``--lidar`` overrides it."""
    mount_height_m: float = 1.05
    """The sensor's height above the ground, only a fallback when a sweep shows too little
    ground to fit (m)."""
    footprint_front_m: float = 2.4
    """The car's body reaches this far ahead of the sensor (m); returns on it are dropped."""
    footprint_rear_m: float = 1.0
    """The car's body reaches this far behind the sensor (m)."""
    footprint_half_width_m: float = 0.7
    """Half the car's width (m)."""
    detector: DetectorConfig = field(default_factory=_real_cloud_detector)
    """The same detector the car runs (``sensors.lidar.detector``), set for real ground:
    copy this section there to run it on the car."""


@dataclass(slots=True)
class SensorsConfig:
    """Every receiver the Sensor Manager builds."""

    gps: GpsConfig = field(default_factory=GpsConfig)
    imu: ImuConfig = field(default_factory=ImuConfig)
    can: CanConfig = field(default_factory=CanConfig)
    lidar: LidarConfig = field(default_factory=LidarConfig)
    camera: CameraConfig = field(default_factory=CameraConfig)
    detect: SceneDetectConfig = field(default_factory=SceneDetectConfig)
    queue_length: int = 4096
    stop_timeout_s: float = 1.0
    reconnect_min_s: float = 0.05
    """First wait before reopening a vanished port / bus-off bus; doubles up to reconnect_max_s."""
    reconnect_max_s: float = 1.0
    rate_window_s: float = 2.0
    """Window (s) over which health() reports each source's rate."""
    reader_late_grace_s: float = 0.9
    """Live: how long (s) past a source's ``timeout_s`` its receiver thread may be late (not
    back from its transport, as in a busy process) before the source counts as stale though
    the thread has not seen the sensor fall silent. A silence the thread has seen counts at
    once; within the grace the map and the pose are late, which the controller rides out.
    The same allowance as a late report of the whole executive process
    (``DriveOptions.executive_report_grace_s``): on a loaded 2-core machine a serial reader
    waited 0.5 s in the kernel for its tty's bytes while the IMU sent them on time (issue 19,
    ``bench load``), and 0.4 s stopped the car for it."""
