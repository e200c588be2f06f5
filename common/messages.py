"""Message types for everything that crosses a tier boundary.

Every message is a frozen, slotted dataclass whose first field is ``timestamp_s``: the time (s) on
the run's Clock at which the reading was made (for sensors) or the estimate is valid (for
estimates). Units are in the field names. Frames follow :mod:`common.conventions`: the vehicle
frame has x forward, y left, z up; the world frame is fixed at the start pose; yaw is
counter-clockwise from x.

Array-valued fields are numpy arrays made read-only on construction, so a message cannot be
changed after it was sent. Messages holding arrays compare by identity (``eq=False``).
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass, field
from typing import Any  # noqa: E402

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[Any]
"""A float64 array (converted on construction; any numeric dtype is accepted)."""
IntArray = NDArray[Any]
"""An int64 array (converted on construction)."""


def frozen_array(value: object, dtype: type = np.float64) -> NDArray:  # type: ignore[type-arg]
    """Return ``value`` as a read-only contiguous numpy array of ``dtype``."""
    array: NDArray = np.ascontiguousarray(value, dtype=dtype)  # type: ignore[type-arg]
    if array is value:
        array = array.copy()
    array.setflags(write=False)
    return array


class ConeColour(enum.IntEnum):
    """Cone colour classes of the Formula Student rules (numbers are stable: they are recorded)."""

    UNKNOWN = 0
    BLUE = 1
    YELLOW = 2
    ORANGE = 3
    BIG_ORANGE = 4


class ConeSize(enum.IntEnum):
    """Cone size classes: small 228 x 325 mm, large 285 x 505 mm (numbers are recorded)."""

    UNKNOWN = 0
    SMALL = 1
    LARGE = 2


class AsState(enum.IntEnum):
    """Formula Student autonomous-system states (numbers are recorded)."""

    OFF = 0
    READY = 1
    DRIVING = 2
    EMERGENCY = 3
    FINISHED = 4


class Mission(enum.IntEnum):
    """Formula Student Driverless missions, as the car selects them (``MISSION_SELECT`` on CAN;
    numbers are the wire values and are recorded).

    ``NONE``: no mission selected; ``UNKNOWN``: the car reports a mission the stack cannot run
    (also what a wire value outside this table decodes to). Neither lets the AS leave OFF.
    """

    NONE = 0
    TRACKDRIVE = 1
    AUTOCROSS = 2
    ACCELERATION = 3
    SKIDPAD = 4
    UNKNOWN = 15

    @property
    def selectable(self) -> bool:
        """True for a mission the stack can drive (not NONE or UNKNOWN)."""
        return self not in (Mission.NONE, Mission.UNKNOWN)


class AssiMode(enum.IntEnum):
    """What the autonomous-system status indicators (ASSI) show (numbers are the wire values of
    ``AS_STATUS``): off, yellow or blue, continuous or flashing (2..5 Hz)."""

    OFF = 0
    YELLOW_CONTINUOUS = 1
    YELLOW_FLASHING = 2
    BLUE_CONTINUOUS = 3
    BLUE_FLASHING = 4


# ---------------------------------------------------------------------------------------------
# Raw readings
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class RawBytes:
    """One raw unit of a sensor's wire format, exactly as received.

    ``source`` names the receiver (``gps``, ``imu``, ``lidar``, ``camera``); ``payload`` is one
    NMEA sentence (with CR LF), one IMU packet, one LiDAR UDP datagram (the simulator hands over
    a sweep's packets back to back as one unit of n x 1206 bytes) or one camera datagram.
    """

    timestamp_s: float
    source: str
    payload: bytes


@dataclass(frozen=True, slots=True)
class CanFrame:
    """One CAN frame as it was on the bus (or is to be sent)."""

    timestamp_s: float
    arbitration_id: int
    data: bytes
    is_extended_id: bool = False


@dataclass(frozen=True, slots=True)
class GpsFix:
    """A GNSS fix parsed from NMEA.

    ``course_rad`` is the course over ground as a yaw in the local east-north frame
    (counter-clockwise from east), converted at the edge from NMEA's degrees clockwise from north;
    NaN when unknown, like ``speed_mps``. ``fix_quality`` is the GGA quality (0 invalid, 1 GPS,
    2 DGPS, 4 RTK fixed, 5 RTK float).
    """

    timestamp_s: float
    lat_deg: float
    lon_deg: float
    altitude_m: float = math.nan
    fix_quality: int = 1
    satellites: int = 0
    hdop: float = math.nan
    speed_mps: float = math.nan
    course_rad: float = math.nan
    utc_time_s: float = math.nan
    lat_sigma_m: float = math.nan
    lon_sigma_m: float = math.nan
    """The receiver's own 1-sigma errors of latitude and longitude (m; NMEA GST), NaN (or 0,
    from a recording made before they existed) when it does not say."""


@dataclass(frozen=True, slots=True)
class ImuSample:
    """Specific force (m/s^2) and angular rate (rad/s) in the vehicle frame (gravity in +z)."""

    timestamp_s: float
    accel_x_mps2: float
    accel_y_mps2: float
    accel_z_mps2: float
    gyro_x_radps: float
    gyro_y_radps: float
    gyro_z_radps: float


@dataclass(frozen=True, slots=True)
class WheelSpeeds:
    """Wheel surface speeds (m/s), front-left, front-right, rear-left, rear-right."""

    timestamp_s: float
    front_left_mps: float
    front_right_mps: float
    rear_left_mps: float
    rear_right_mps: float

    @property
    def mean_rear_mps(self) -> float:
        """Mean of the rear wheels (m/s)."""
        return 0.5 * (self.rear_left_mps + self.rear_right_mps)

    @property
    def mean_mps(self) -> float:
        """Mean of all four wheels (m/s)."""
        return 0.25 * (
            self.front_left_mps + self.front_right_mps + self.rear_left_mps + self.rear_right_mps
        )


@dataclass(frozen=True, slots=True)
class SteeringAngle:
    """Measured road-wheel steering angle (rad), positive to the left."""

    timestamp_s: float
    angle_rad: float


@dataclass(frozen=True, slots=True)
class RemoteStop:
    """State of the remote emergency stop (RES): ``emergency`` stops the car, ``go`` starts it."""

    timestamp_s: float
    emergency: bool
    go: bool


@dataclass(frozen=True, slots=True)
class MissionSelect:
    """The mission the car selected (``MISSION_SELECT`` on CAN).

    ``raw_value`` is the number on the wire: for ``Mission.UNKNOWN`` it tells which unknown
    value was sent."""

    timestamp_s: float
    mission: Mission
    raw_value: int = -1


@dataclass(frozen=True, slots=True)
class AsStatus:
    """What the stack reports to the car (``AS_STATUS`` on CAN): AS state, mission, lap and
    the ASSI mode for that state. ``lap`` counts laps started (0 before the first)."""

    timestamp_s: float
    state: AsState
    mission: Mission
    lap: int
    assi: AssiMode


@dataclass(frozen=True, slots=True)
class ConeDetection:
    """One cone seen by a sensor, in the vehicle frame at ``timestamp_s`` (when it was seen).

    ``confidence`` is 0..1 (1 for LiDAR); ``height_m`` and ``width_m`` are NaN when unknown.
    """

    timestamp_s: float
    x_m: float
    y_m: float
    colour: ConeColour = ConeColour.UNKNOWN
    size: ConeSize = ConeSize.UNKNOWN
    confidence: float = 1.0
    height_m: float = math.nan
    width_m: float = math.nan

    @property
    def range_m(self) -> float:
        """Distance from the vehicle origin (m)."""
        return math.hypot(self.x_m, self.y_m)


@dataclass(frozen=True, slots=True)
class LidarCones:
    """Cones detected in one LiDAR sweep (``timestamp_s`` = end of the sweep)."""

    timestamp_s: float
    cones: tuple[ConeDetection, ...]
    sweep_start_s: float = math.nan
    point_count: int = 0


@dataclass(frozen=True, slots=True)
class CameraCones:
    """Cones detected in one camera frame (``timestamp_s`` = image time)."""

    timestamp_s: float
    cones: tuple[ConeDetection, ...]
    frame_id: int = 0


@dataclass(frozen=True, slots=True, eq=False)
class LidarPoints:
    """One assembled LiDAR sweep: ``points`` is (N, 4) x, y, z (m, sensor frame), intensity.

    ``times_s`` (N,) is each return's time on the Clock; ``rings`` (N,) the laser index 0..15.
    ``return_count`` is the sweep's returns before any window chose some at decoding (0: the
    points are all of them); ``timestamp_s`` and ``start_s`` are the times of the sweep's last
    and first returns, chosen or not (``start_s`` nan: the earliest of ``times_s``).
    """

    timestamp_s: float
    points: FloatArray
    times_s: FloatArray
    rings: IntArray
    return_count: int = 0
    start_s: float = math.nan

    def __post_init__(self) -> None:
        object.__setattr__(self, "points", frozen_array(self.points))
        object.__setattr__(self, "times_s", frozen_array(self.times_s))
        object.__setattr__(self, "rings", frozen_array(self.rings, np.int64))


Reading = (
    GpsFix
    | ImuSample
    | WheelSpeeds
    | SteeringAngle
    | RemoteStop
    | MissionSelect
    | LidarCones
    | CameraCones
    | CanFrame
    | RawBytes
)
"""Anything a receiver (or the simulator, or the player) hands to Main."""


# ---------------------------------------------------------------------------------------------
# Estimates
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True, slots=True, eq=False)
class PoseEstimate:
    """The car's estimated state: position and yaw in the world frame, velocities in the
    vehicle frame (``vx_mps`` forward, ``vy_mps`` left), yaw rate counter-clockwise.

    ``covariance`` is (3, 3) over (x_m, y_m, yaw_rad).
    """

    timestamp_s: float
    x_m: float
    y_m: float
    yaw_rad: float
    vx_mps: float = 0.0
    vy_mps: float = 0.0
    yaw_rate_radps: float = 0.0
    covariance: FloatArray = field(default_factory=lambda: np.zeros((3, 3)))

    def __post_init__(self) -> None:
        cov = frozen_array(self.covariance)
        if cov.shape != (3, 3):
            raise ValueError(f"PoseEstimate.covariance must be (3, 3), got {cov.shape}")
        object.__setattr__(self, "covariance", cov)

    @property
    def speed_mps(self) -> float:
        """Speed over ground (m/s)."""
        return math.hypot(self.vx_mps, self.vy_mps)

    @property
    def position_sigma_m(self) -> float:
        """Square root of the largest eigenvalue of the position covariance (m)."""
        return float(math.sqrt(max(np.linalg.eigvalsh(self.covariance[:2, :2]).max(), 0.0)))


@dataclass(frozen=True, slots=True, eq=False)
class ConeMap:
    """Cones in the world frame as arrays, one row per cone.

    ``xy_m`` (N, 2); ``covariance`` (N, 2, 2); ``colour`` (N,) :class:`ConeColour` values;
    ``size`` (N,) :class:`ConeSize` values; ``confidence`` (N,) >= 0 (smoother confidence, or
    1 for SLAM landmarks); ``ids`` (N,) stable landmark ids.
    """

    xy_m: FloatArray
    covariance: FloatArray
    colour: IntArray
    size: IntArray
    confidence: FloatArray
    ids: IntArray

    def __post_init__(self) -> None:
        xy = frozen_array(self.xy_m).reshape(-1, 2)
        n = xy.shape[0]
        object.__setattr__(self, "xy_m", xy)
        object.__setattr__(self, "covariance", frozen_array(self.covariance).reshape(n, 2, 2))
        for name, dtype in (("colour", np.int64), ("size", np.int64), ("ids", np.int64)):
            arr = frozen_array(getattr(self, name), dtype)
            if arr.shape != (n,):
                raise ValueError(f"ConeMap.{name} must be ({n},), got {arr.shape}")
            object.__setattr__(self, name, arr)
        conf = frozen_array(self.confidence)
        if conf.shape != (n,):
            raise ValueError(f"ConeMap.confidence must be ({n},), got {conf.shape}")
        object.__setattr__(self, "confidence", conf)

    def __len__(self) -> int:
        return int(self.xy_m.shape[0])

    @classmethod
    def empty(cls) -> ConeMap:
        """A map with no cones."""
        return cls(
            xy_m=np.zeros((0, 2)),
            covariance=np.zeros((0, 2, 2)),
            colour=np.zeros(0, np.int64),
            size=np.zeros(0, np.int64),
            confidence=np.zeros(0),
            ids=np.zeros(0, np.int64),
        )


@dataclass(frozen=True, slots=True, eq=False)
class MapState:
    """What the Mapper knows: the pose and the cones, at ``timestamp_s``."""

    timestamp_s: float
    pose: PoseEstimate
    cones: ConeMap
    loop_closed: bool = False
    backend: str = ""
    map_frozen: bool = False


# ---------------------------------------------------------------------------------------------
# Plan
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True, slots=True, eq=False)
class Baseframe:
    """Samples of the baseframe curve, each array (M,): arc length, position, heading, curvature.

    ``closed`` is True for a periodic (lap) baseframe whose length is ``length_m``.
    """

    s_m: FloatArray
    x_m: FloatArray
    y_m: FloatArray
    heading_rad: FloatArray
    curvature_1pm: FloatArray
    closed: bool = True
    length_m: float = 0.0

    def __post_init__(self) -> None:
        for name in ("s_m", "x_m", "y_m", "heading_rad", "curvature_1pm"):
            object.__setattr__(self, name, frozen_array(getattr(self, name)))


@dataclass(frozen=True, slots=True, eq=False)
class TargetStates:
    """The chosen manoeuvre discretised into timed target states, each array (K,).

    ``t_s`` are absolute Clock times; ``speed_mps`` the target speed at each state.
    """

    t_s: FloatArray
    x_m: FloatArray
    y_m: FloatArray
    yaw_rad: FloatArray
    speed_mps: FloatArray
    curvature_1pm: FloatArray

    def __post_init__(self) -> None:
        for name in ("t_s", "x_m", "y_m", "yaw_rad", "speed_mps", "curvature_1pm"):
            object.__setattr__(self, name, frozen_array(getattr(self, name)))

    def __len__(self) -> int:
        return int(self.t_s.shape[0])


@dataclass(frozen=True, slots=True, eq=False)
class Plan:
    """The path planner's output at ``timestamp_s``.

    ``candidates`` are the candidate manoeuvres' (K, 2) world paths (for drawing),
    ``chosen_index`` the chosen one's index in them (-1 when none is feasible).
    """

    timestamp_s: float
    baseframe: Baseframe | None
    manoeuvre: TargetStates
    target_speed_mps: float
    candidates: tuple[FloatArray, ...] = ()
    chosen_index: int = -1
    waypoints_xy_m: FloatArray = field(default_factory=lambda: np.zeros((0, 2)))
    lap: int = 0

    def __post_init__(self) -> None:
        object.__setattr__(
            self, "waypoints_xy_m", frozen_array(self.waypoints_xy_m).reshape(-1, 2)
        )
        object.__setattr__(
            self, "candidates", tuple(frozen_array(c).reshape(-1, 2) for c in self.candidates)
        )


# ---------------------------------------------------------------------------------------------
# Commands and health
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class ActuatorCommand:
    """What the controller asks of the car: throttle and brake 0..1, road-wheel steering (rad).

    Throttle and brake are never both above zero. Construction rejects NaN and out-of-range
    values with ``ValueError``: a bad command must never reach the actuators.
    """

    timestamp_s: float
    throttle: float
    brake: float
    steering_rad: float
    state: AsState = AsState.DRIVING

    def __post_init__(self) -> None:
        for name in ("throttle", "brake", "steering_rad"):
            value = getattr(self, name)
            if not math.isfinite(value):
                raise ValueError(f"ActuatorCommand.{name} is not finite: {value!r}")
        if not 0.0 <= self.throttle <= 1.0:
            raise ValueError(f"ActuatorCommand.throttle {self.throttle} outside 0..1")
        if not 0.0 <= self.brake <= 1.0:
            raise ValueError(f"ActuatorCommand.brake {self.brake} outside 0..1")
        if self.throttle > 0.0 and self.brake > 0.0:
            raise ValueError("ActuatorCommand: throttle and brake both above zero")

    @classmethod
    def full_brake(cls, timestamp_s: float, state: AsState = AsState.EMERGENCY) -> ActuatorCommand:
        """Full braking, wheels straight."""
        return cls(timestamp_s, 0.0, 1.0, 0.0, state)


@dataclass(frozen=True, slots=True)
class SourceHealth:
    """Freshness of one sensor source as seen by the Sensor Manager at ``timestamp_s``.

    ``age_s`` is the time since its last reading (inf if none yet); ``stale`` is True when
    that age passed the source's timeout; ``rejects`` counts rejected input by reason.
    """

    timestamp_s: float
    source: str
    alive: bool
    rate_hz: float
    age_s: float
    errors: int
    stale: bool
    rejects: tuple[tuple[str, int], ...] = ()


@dataclass(frozen=True, slots=True)
class Health:
    """Health of every source, plus the stack's own state."""

    timestamp_s: float
    sources: tuple[SourceHealth, ...]
    state: AsState = AsState.OFF
    stop_reason: str = ""

    def stale_sources(self) -> tuple[str, ...]:
        """Names of the sources that are stale."""
        return tuple(s.source for s in self.sources if s.stale)


@dataclass(frozen=True, slots=True)
class GroundTruth:
    """The simulated car's true state (never fed to the stack; for evaluation only)."""

    timestamp_s: float
    x_m: float
    y_m: float
    yaw_rad: float
    vx_mps: float
    vy_mps: float
    yaw_rate_radps: float
    steering_rad: float = 0.0
