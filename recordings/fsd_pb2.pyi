from google.protobuf.internal import containers as _containers
from google.protobuf.internal import enum_type_wrapper as _enum_type_wrapper
from google.protobuf import descriptor as _descriptor
from google.protobuf import message as _message
from collections.abc import Iterable as _Iterable, Mapping as _Mapping
from typing import ClassVar as _ClassVar, Optional as _Optional, Union as _Union

DESCRIPTOR: _descriptor.FileDescriptor

class ConeColour(int, metaclass=_enum_type_wrapper.EnumTypeWrapper):
    __slots__ = ()
    CONE_COLOUR_UNKNOWN: _ClassVar[ConeColour]
    CONE_COLOUR_BLUE: _ClassVar[ConeColour]
    CONE_COLOUR_YELLOW: _ClassVar[ConeColour]
    CONE_COLOUR_ORANGE: _ClassVar[ConeColour]
    CONE_COLOUR_BIG_ORANGE: _ClassVar[ConeColour]

class ConeSize(int, metaclass=_enum_type_wrapper.EnumTypeWrapper):
    __slots__ = ()
    CONE_SIZE_UNKNOWN: _ClassVar[ConeSize]
    CONE_SIZE_SMALL: _ClassVar[ConeSize]
    CONE_SIZE_LARGE: _ClassVar[ConeSize]

class AsState(int, metaclass=_enum_type_wrapper.EnumTypeWrapper):
    __slots__ = ()
    AS_STATE_OFF: _ClassVar[AsState]
    AS_STATE_READY: _ClassVar[AsState]
    AS_STATE_DRIVING: _ClassVar[AsState]
    AS_STATE_EMERGENCY: _ClassVar[AsState]
    AS_STATE_FINISHED: _ClassVar[AsState]
CONE_COLOUR_UNKNOWN: ConeColour
CONE_COLOUR_BLUE: ConeColour
CONE_COLOUR_YELLOW: ConeColour
CONE_COLOUR_ORANGE: ConeColour
CONE_COLOUR_BIG_ORANGE: ConeColour
CONE_SIZE_UNKNOWN: ConeSize
CONE_SIZE_SMALL: ConeSize
CONE_SIZE_LARGE: ConeSize
AS_STATE_OFF: AsState
AS_STATE_READY: AsState
AS_STATE_DRIVING: AsState
AS_STATE_EMERGENCY: AsState
AS_STATE_FINISHED: AsState

class RawBytes(_message.Message):
    __slots__ = ("timestamp_s", "source", "payload")
    TIMESTAMP_S_FIELD_NUMBER: _ClassVar[int]
    SOURCE_FIELD_NUMBER: _ClassVar[int]
    PAYLOAD_FIELD_NUMBER: _ClassVar[int]
    timestamp_s: float
    source: str
    payload: bytes
    def __init__(self, timestamp_s: _Optional[float] = ..., source: _Optional[str] = ..., payload: _Optional[bytes] = ...) -> None: ...

class CanFrame(_message.Message):
    __slots__ = ("timestamp_s", "arbitration_id", "data", "is_extended_id")
    TIMESTAMP_S_FIELD_NUMBER: _ClassVar[int]
    ARBITRATION_ID_FIELD_NUMBER: _ClassVar[int]
    DATA_FIELD_NUMBER: _ClassVar[int]
    IS_EXTENDED_ID_FIELD_NUMBER: _ClassVar[int]
    timestamp_s: float
    arbitration_id: int
    data: bytes
    is_extended_id: bool
    def __init__(self, timestamp_s: _Optional[float] = ..., arbitration_id: _Optional[int] = ..., data: _Optional[bytes] = ..., is_extended_id: _Optional[bool] = ...) -> None: ...

class GpsFix(_message.Message):
    __slots__ = ("timestamp_s", "lat_deg", "lon_deg", "altitude_m", "fix_quality", "satellites", "hdop", "speed_mps", "course_rad", "utc_time_s", "lat_sigma_m", "lon_sigma_m")
    TIMESTAMP_S_FIELD_NUMBER: _ClassVar[int]
    LAT_DEG_FIELD_NUMBER: _ClassVar[int]
    LON_DEG_FIELD_NUMBER: _ClassVar[int]
    ALTITUDE_M_FIELD_NUMBER: _ClassVar[int]
    FIX_QUALITY_FIELD_NUMBER: _ClassVar[int]
    SATELLITES_FIELD_NUMBER: _ClassVar[int]
    HDOP_FIELD_NUMBER: _ClassVar[int]
    SPEED_MPS_FIELD_NUMBER: _ClassVar[int]
    COURSE_RAD_FIELD_NUMBER: _ClassVar[int]
    UTC_TIME_S_FIELD_NUMBER: _ClassVar[int]
    LAT_SIGMA_M_FIELD_NUMBER: _ClassVar[int]
    LON_SIGMA_M_FIELD_NUMBER: _ClassVar[int]
    timestamp_s: float
    lat_deg: float
    lon_deg: float
    altitude_m: float
    fix_quality: int
    satellites: int
    hdop: float
    speed_mps: float
    course_rad: float
    utc_time_s: float
    lat_sigma_m: float
    lon_sigma_m: float
    def __init__(self, timestamp_s: _Optional[float] = ..., lat_deg: _Optional[float] = ..., lon_deg: _Optional[float] = ..., altitude_m: _Optional[float] = ..., fix_quality: _Optional[int] = ..., satellites: _Optional[int] = ..., hdop: _Optional[float] = ..., speed_mps: _Optional[float] = ..., course_rad: _Optional[float] = ..., utc_time_s: _Optional[float] = ..., lat_sigma_m: _Optional[float] = ..., lon_sigma_m: _Optional[float] = ...) -> None: ...

class ImuSample(_message.Message):
    __slots__ = ("timestamp_s", "accel_x_mps2", "accel_y_mps2", "accel_z_mps2", "gyro_x_radps", "gyro_y_radps", "gyro_z_radps")
    TIMESTAMP_S_FIELD_NUMBER: _ClassVar[int]
    ACCEL_X_MPS2_FIELD_NUMBER: _ClassVar[int]
    ACCEL_Y_MPS2_FIELD_NUMBER: _ClassVar[int]
    ACCEL_Z_MPS2_FIELD_NUMBER: _ClassVar[int]
    GYRO_X_RADPS_FIELD_NUMBER: _ClassVar[int]
    GYRO_Y_RADPS_FIELD_NUMBER: _ClassVar[int]
    GYRO_Z_RADPS_FIELD_NUMBER: _ClassVar[int]
    timestamp_s: float
    accel_x_mps2: float
    accel_y_mps2: float
    accel_z_mps2: float
    gyro_x_radps: float
    gyro_y_radps: float
    gyro_z_radps: float
    def __init__(self, timestamp_s: _Optional[float] = ..., accel_x_mps2: _Optional[float] = ..., accel_y_mps2: _Optional[float] = ..., accel_z_mps2: _Optional[float] = ..., gyro_x_radps: _Optional[float] = ..., gyro_y_radps: _Optional[float] = ..., gyro_z_radps: _Optional[float] = ...) -> None: ...

class WheelSpeeds(_message.Message):
    __slots__ = ("timestamp_s", "front_left_mps", "front_right_mps", "rear_left_mps", "rear_right_mps")
    TIMESTAMP_S_FIELD_NUMBER: _ClassVar[int]
    FRONT_LEFT_MPS_FIELD_NUMBER: _ClassVar[int]
    FRONT_RIGHT_MPS_FIELD_NUMBER: _ClassVar[int]
    REAR_LEFT_MPS_FIELD_NUMBER: _ClassVar[int]
    REAR_RIGHT_MPS_FIELD_NUMBER: _ClassVar[int]
    timestamp_s: float
    front_left_mps: float
    front_right_mps: float
    rear_left_mps: float
    rear_right_mps: float
    def __init__(self, timestamp_s: _Optional[float] = ..., front_left_mps: _Optional[float] = ..., front_right_mps: _Optional[float] = ..., rear_left_mps: _Optional[float] = ..., rear_right_mps: _Optional[float] = ...) -> None: ...

class SteeringAngle(_message.Message):
    __slots__ = ("timestamp_s", "angle_rad")
    TIMESTAMP_S_FIELD_NUMBER: _ClassVar[int]
    ANGLE_RAD_FIELD_NUMBER: _ClassVar[int]
    timestamp_s: float
    angle_rad: float
    def __init__(self, timestamp_s: _Optional[float] = ..., angle_rad: _Optional[float] = ...) -> None: ...

class RemoteStop(_message.Message):
    __slots__ = ("timestamp_s", "emergency", "go")
    TIMESTAMP_S_FIELD_NUMBER: _ClassVar[int]
    EMERGENCY_FIELD_NUMBER: _ClassVar[int]
    GO_FIELD_NUMBER: _ClassVar[int]
    timestamp_s: float
    emergency: bool
    go: bool
    def __init__(self, timestamp_s: _Optional[float] = ..., emergency: _Optional[bool] = ..., go: _Optional[bool] = ...) -> None: ...

class ConeDetection(_message.Message):
    __slots__ = ("timestamp_s", "x_m", "y_m", "colour", "size", "confidence", "height_m", "width_m")
    TIMESTAMP_S_FIELD_NUMBER: _ClassVar[int]
    X_M_FIELD_NUMBER: _ClassVar[int]
    Y_M_FIELD_NUMBER: _ClassVar[int]
    COLOUR_FIELD_NUMBER: _ClassVar[int]
    SIZE_FIELD_NUMBER: _ClassVar[int]
    CONFIDENCE_FIELD_NUMBER: _ClassVar[int]
    HEIGHT_M_FIELD_NUMBER: _ClassVar[int]
    WIDTH_M_FIELD_NUMBER: _ClassVar[int]
    timestamp_s: float
    x_m: float
    y_m: float
    colour: ConeColour
    size: ConeSize
    confidence: float
    height_m: float
    width_m: float
    def __init__(self, timestamp_s: _Optional[float] = ..., x_m: _Optional[float] = ..., y_m: _Optional[float] = ..., colour: _Optional[_Union[ConeColour, str]] = ..., size: _Optional[_Union[ConeSize, str]] = ..., confidence: _Optional[float] = ..., height_m: _Optional[float] = ..., width_m: _Optional[float] = ...) -> None: ...

class LidarCones(_message.Message):
    __slots__ = ("timestamp_s", "cones", "sweep_start_s", "point_count")
    TIMESTAMP_S_FIELD_NUMBER: _ClassVar[int]
    CONES_FIELD_NUMBER: _ClassVar[int]
    SWEEP_START_S_FIELD_NUMBER: _ClassVar[int]
    POINT_COUNT_FIELD_NUMBER: _ClassVar[int]
    timestamp_s: float
    cones: _containers.RepeatedCompositeFieldContainer[ConeDetection]
    sweep_start_s: float
    point_count: int
    def __init__(self, timestamp_s: _Optional[float] = ..., cones: _Optional[_Iterable[_Union[ConeDetection, _Mapping]]] = ..., sweep_start_s: _Optional[float] = ..., point_count: _Optional[int] = ...) -> None: ...

class CameraCones(_message.Message):
    __slots__ = ("timestamp_s", "cones", "frame_id")
    TIMESTAMP_S_FIELD_NUMBER: _ClassVar[int]
    CONES_FIELD_NUMBER: _ClassVar[int]
    FRAME_ID_FIELD_NUMBER: _ClassVar[int]
    timestamp_s: float
    cones: _containers.RepeatedCompositeFieldContainer[ConeDetection]
    frame_id: int
    def __init__(self, timestamp_s: _Optional[float] = ..., cones: _Optional[_Iterable[_Union[ConeDetection, _Mapping]]] = ..., frame_id: _Optional[int] = ...) -> None: ...

class LidarPoints(_message.Message):
    __slots__ = ("timestamp_s", "points", "times_s", "rings", "return_count", "start_s")
    TIMESTAMP_S_FIELD_NUMBER: _ClassVar[int]
    POINTS_FIELD_NUMBER: _ClassVar[int]
    TIMES_S_FIELD_NUMBER: _ClassVar[int]
    RINGS_FIELD_NUMBER: _ClassVar[int]
    RETURN_COUNT_FIELD_NUMBER: _ClassVar[int]
    START_S_FIELD_NUMBER: _ClassVar[int]
    timestamp_s: float
    points: _containers.RepeatedScalarFieldContainer[float]
    times_s: _containers.RepeatedScalarFieldContainer[float]
    rings: _containers.RepeatedScalarFieldContainer[int]
    return_count: int
    start_s: float
    def __init__(self, timestamp_s: _Optional[float] = ..., points: _Optional[_Iterable[float]] = ..., times_s: _Optional[_Iterable[float]] = ..., rings: _Optional[_Iterable[int]] = ..., return_count: _Optional[int] = ..., start_s: _Optional[float] = ...) -> None: ...

class PoseEstimate(_message.Message):
    __slots__ = ("timestamp_s", "x_m", "y_m", "yaw_rad", "vx_mps", "vy_mps", "yaw_rate_radps", "covariance")
    TIMESTAMP_S_FIELD_NUMBER: _ClassVar[int]
    X_M_FIELD_NUMBER: _ClassVar[int]
    Y_M_FIELD_NUMBER: _ClassVar[int]
    YAW_RAD_FIELD_NUMBER: _ClassVar[int]
    VX_MPS_FIELD_NUMBER: _ClassVar[int]
    VY_MPS_FIELD_NUMBER: _ClassVar[int]
    YAW_RATE_RADPS_FIELD_NUMBER: _ClassVar[int]
    COVARIANCE_FIELD_NUMBER: _ClassVar[int]
    timestamp_s: float
    x_m: float
    y_m: float
    yaw_rad: float
    vx_mps: float
    vy_mps: float
    yaw_rate_radps: float
    covariance: _containers.RepeatedScalarFieldContainer[float]
    def __init__(self, timestamp_s: _Optional[float] = ..., x_m: _Optional[float] = ..., y_m: _Optional[float] = ..., yaw_rad: _Optional[float] = ..., vx_mps: _Optional[float] = ..., vy_mps: _Optional[float] = ..., yaw_rate_radps: _Optional[float] = ..., covariance: _Optional[_Iterable[float]] = ...) -> None: ...

class ConeMap(_message.Message):
    __slots__ = ("x_m", "y_m", "covariance", "colour", "size", "confidence", "ids")
    X_M_FIELD_NUMBER: _ClassVar[int]
    Y_M_FIELD_NUMBER: _ClassVar[int]
    COVARIANCE_FIELD_NUMBER: _ClassVar[int]
    COLOUR_FIELD_NUMBER: _ClassVar[int]
    SIZE_FIELD_NUMBER: _ClassVar[int]
    CONFIDENCE_FIELD_NUMBER: _ClassVar[int]
    IDS_FIELD_NUMBER: _ClassVar[int]
    x_m: _containers.RepeatedScalarFieldContainer[float]
    y_m: _containers.RepeatedScalarFieldContainer[float]
    covariance: _containers.RepeatedScalarFieldContainer[float]
    colour: _containers.RepeatedScalarFieldContainer[ConeColour]
    size: _containers.RepeatedScalarFieldContainer[ConeSize]
    confidence: _containers.RepeatedScalarFieldContainer[float]
    ids: _containers.RepeatedScalarFieldContainer[int]
    def __init__(self, x_m: _Optional[_Iterable[float]] = ..., y_m: _Optional[_Iterable[float]] = ..., covariance: _Optional[_Iterable[float]] = ..., colour: _Optional[_Iterable[_Union[ConeColour, str]]] = ..., size: _Optional[_Iterable[_Union[ConeSize, str]]] = ..., confidence: _Optional[_Iterable[float]] = ..., ids: _Optional[_Iterable[int]] = ...) -> None: ...

class MapState(_message.Message):
    __slots__ = ("timestamp_s", "pose", "cones", "loop_closed", "backend", "map_frozen")
    TIMESTAMP_S_FIELD_NUMBER: _ClassVar[int]
    POSE_FIELD_NUMBER: _ClassVar[int]
    CONES_FIELD_NUMBER: _ClassVar[int]
    LOOP_CLOSED_FIELD_NUMBER: _ClassVar[int]
    BACKEND_FIELD_NUMBER: _ClassVar[int]
    MAP_FROZEN_FIELD_NUMBER: _ClassVar[int]
    timestamp_s: float
    pose: PoseEstimate
    cones: ConeMap
    loop_closed: bool
    backend: str
    map_frozen: bool
    def __init__(self, timestamp_s: _Optional[float] = ..., pose: _Optional[_Union[PoseEstimate, _Mapping]] = ..., cones: _Optional[_Union[ConeMap, _Mapping]] = ..., loop_closed: _Optional[bool] = ..., backend: _Optional[str] = ..., map_frozen: _Optional[bool] = ...) -> None: ...

class Baseframe(_message.Message):
    __slots__ = ("s_m", "x_m", "y_m", "heading_rad", "curvature_1pm", "closed", "length_m")
    S_M_FIELD_NUMBER: _ClassVar[int]
    X_M_FIELD_NUMBER: _ClassVar[int]
    Y_M_FIELD_NUMBER: _ClassVar[int]
    HEADING_RAD_FIELD_NUMBER: _ClassVar[int]
    CURVATURE_1PM_FIELD_NUMBER: _ClassVar[int]
    CLOSED_FIELD_NUMBER: _ClassVar[int]
    LENGTH_M_FIELD_NUMBER: _ClassVar[int]
    s_m: _containers.RepeatedScalarFieldContainer[float]
    x_m: _containers.RepeatedScalarFieldContainer[float]
    y_m: _containers.RepeatedScalarFieldContainer[float]
    heading_rad: _containers.RepeatedScalarFieldContainer[float]
    curvature_1pm: _containers.RepeatedScalarFieldContainer[float]
    closed: bool
    length_m: float
    def __init__(self, s_m: _Optional[_Iterable[float]] = ..., x_m: _Optional[_Iterable[float]] = ..., y_m: _Optional[_Iterable[float]] = ..., heading_rad: _Optional[_Iterable[float]] = ..., curvature_1pm: _Optional[_Iterable[float]] = ..., closed: _Optional[bool] = ..., length_m: _Optional[float] = ...) -> None: ...

class TargetStates(_message.Message):
    __slots__ = ("t_s", "x_m", "y_m", "yaw_rad", "speed_mps", "curvature_1pm")
    T_S_FIELD_NUMBER: _ClassVar[int]
    X_M_FIELD_NUMBER: _ClassVar[int]
    Y_M_FIELD_NUMBER: _ClassVar[int]
    YAW_RAD_FIELD_NUMBER: _ClassVar[int]
    SPEED_MPS_FIELD_NUMBER: _ClassVar[int]
    CURVATURE_1PM_FIELD_NUMBER: _ClassVar[int]
    t_s: _containers.RepeatedScalarFieldContainer[float]
    x_m: _containers.RepeatedScalarFieldContainer[float]
    y_m: _containers.RepeatedScalarFieldContainer[float]
    yaw_rad: _containers.RepeatedScalarFieldContainer[float]
    speed_mps: _containers.RepeatedScalarFieldContainer[float]
    curvature_1pm: _containers.RepeatedScalarFieldContainer[float]
    def __init__(self, t_s: _Optional[_Iterable[float]] = ..., x_m: _Optional[_Iterable[float]] = ..., y_m: _Optional[_Iterable[float]] = ..., yaw_rad: _Optional[_Iterable[float]] = ..., speed_mps: _Optional[_Iterable[float]] = ..., curvature_1pm: _Optional[_Iterable[float]] = ...) -> None: ...

class Path2D(_message.Message):
    __slots__ = ("x_m", "y_m")
    X_M_FIELD_NUMBER: _ClassVar[int]
    Y_M_FIELD_NUMBER: _ClassVar[int]
    x_m: _containers.RepeatedScalarFieldContainer[float]
    y_m: _containers.RepeatedScalarFieldContainer[float]
    def __init__(self, x_m: _Optional[_Iterable[float]] = ..., y_m: _Optional[_Iterable[float]] = ...) -> None: ...

class Plan(_message.Message):
    __slots__ = ("timestamp_s", "baseframe", "manoeuvre", "target_speed_mps", "candidates", "chosen_index", "waypoints", "lap")
    TIMESTAMP_S_FIELD_NUMBER: _ClassVar[int]
    BASEFRAME_FIELD_NUMBER: _ClassVar[int]
    MANOEUVRE_FIELD_NUMBER: _ClassVar[int]
    TARGET_SPEED_MPS_FIELD_NUMBER: _ClassVar[int]
    CANDIDATES_FIELD_NUMBER: _ClassVar[int]
    CHOSEN_INDEX_FIELD_NUMBER: _ClassVar[int]
    WAYPOINTS_FIELD_NUMBER: _ClassVar[int]
    LAP_FIELD_NUMBER: _ClassVar[int]
    timestamp_s: float
    baseframe: Baseframe
    manoeuvre: TargetStates
    target_speed_mps: float
    candidates: _containers.RepeatedCompositeFieldContainer[Path2D]
    chosen_index: int
    waypoints: Path2D
    lap: int
    def __init__(self, timestamp_s: _Optional[float] = ..., baseframe: _Optional[_Union[Baseframe, _Mapping]] = ..., manoeuvre: _Optional[_Union[TargetStates, _Mapping]] = ..., target_speed_mps: _Optional[float] = ..., candidates: _Optional[_Iterable[_Union[Path2D, _Mapping]]] = ..., chosen_index: _Optional[int] = ..., waypoints: _Optional[_Union[Path2D, _Mapping]] = ..., lap: _Optional[int] = ...) -> None: ...

class ActuatorCommand(_message.Message):
    __slots__ = ("timestamp_s", "throttle", "brake", "steering_rad", "state")
    TIMESTAMP_S_FIELD_NUMBER: _ClassVar[int]
    THROTTLE_FIELD_NUMBER: _ClassVar[int]
    BRAKE_FIELD_NUMBER: _ClassVar[int]
    STEERING_RAD_FIELD_NUMBER: _ClassVar[int]
    STATE_FIELD_NUMBER: _ClassVar[int]
    timestamp_s: float
    throttle: float
    brake: float
    steering_rad: float
    state: AsState
    def __init__(self, timestamp_s: _Optional[float] = ..., throttle: _Optional[float] = ..., brake: _Optional[float] = ..., steering_rad: _Optional[float] = ..., state: _Optional[_Union[AsState, str]] = ...) -> None: ...

class RejectCount(_message.Message):
    __slots__ = ("reason", "count")
    REASON_FIELD_NUMBER: _ClassVar[int]
    COUNT_FIELD_NUMBER: _ClassVar[int]
    reason: str
    count: int
    def __init__(self, reason: _Optional[str] = ..., count: _Optional[int] = ...) -> None: ...

class SourceHealth(_message.Message):
    __slots__ = ("timestamp_s", "source", "alive", "rate_hz", "age_s", "errors", "stale", "rejects")
    TIMESTAMP_S_FIELD_NUMBER: _ClassVar[int]
    SOURCE_FIELD_NUMBER: _ClassVar[int]
    ALIVE_FIELD_NUMBER: _ClassVar[int]
    RATE_HZ_FIELD_NUMBER: _ClassVar[int]
    AGE_S_FIELD_NUMBER: _ClassVar[int]
    ERRORS_FIELD_NUMBER: _ClassVar[int]
    STALE_FIELD_NUMBER: _ClassVar[int]
    REJECTS_FIELD_NUMBER: _ClassVar[int]
    timestamp_s: float
    source: str
    alive: bool
    rate_hz: float
    age_s: float
    errors: int
    stale: bool
    rejects: _containers.RepeatedCompositeFieldContainer[RejectCount]
    def __init__(self, timestamp_s: _Optional[float] = ..., source: _Optional[str] = ..., alive: _Optional[bool] = ..., rate_hz: _Optional[float] = ..., age_s: _Optional[float] = ..., errors: _Optional[int] = ..., stale: _Optional[bool] = ..., rejects: _Optional[_Iterable[_Union[RejectCount, _Mapping]]] = ...) -> None: ...

class Health(_message.Message):
    __slots__ = ("timestamp_s", "sources", "state", "stop_reason")
    TIMESTAMP_S_FIELD_NUMBER: _ClassVar[int]
    SOURCES_FIELD_NUMBER: _ClassVar[int]
    STATE_FIELD_NUMBER: _ClassVar[int]
    STOP_REASON_FIELD_NUMBER: _ClassVar[int]
    timestamp_s: float
    sources: _containers.RepeatedCompositeFieldContainer[SourceHealth]
    state: AsState
    stop_reason: str
    def __init__(self, timestamp_s: _Optional[float] = ..., sources: _Optional[_Iterable[_Union[SourceHealth, _Mapping]]] = ..., state: _Optional[_Union[AsState, str]] = ..., stop_reason: _Optional[str] = ...) -> None: ...

class GroundTruth(_message.Message):
    __slots__ = ("timestamp_s", "x_m", "y_m", "yaw_rad", "vx_mps", "vy_mps", "yaw_rate_radps", "steering_rad")
    TIMESTAMP_S_FIELD_NUMBER: _ClassVar[int]
    X_M_FIELD_NUMBER: _ClassVar[int]
    Y_M_FIELD_NUMBER: _ClassVar[int]
    YAW_RAD_FIELD_NUMBER: _ClassVar[int]
    VX_MPS_FIELD_NUMBER: _ClassVar[int]
    VY_MPS_FIELD_NUMBER: _ClassVar[int]
    YAW_RATE_RADPS_FIELD_NUMBER: _ClassVar[int]
    STEERING_RAD_FIELD_NUMBER: _ClassVar[int]
    timestamp_s: float
    x_m: float
    y_m: float
    yaw_rad: float
    vx_mps: float
    vy_mps: float
    yaw_rate_radps: float
    steering_rad: float
    def __init__(self, timestamp_s: _Optional[float] = ..., x_m: _Optional[float] = ..., y_m: _Optional[float] = ..., yaw_rad: _Optional[float] = ..., vx_mps: _Optional[float] = ..., vy_mps: _Optional[float] = ..., yaw_rate_radps: _Optional[float] = ..., steering_rad: _Optional[float] = ...) -> None: ...

class PoseError(_message.Message):
    __slots__ = ("timestamp_s", "position_m", "x_m", "y_m", "heading_rad")
    TIMESTAMP_S_FIELD_NUMBER: _ClassVar[int]
    POSITION_M_FIELD_NUMBER: _ClassVar[int]
    X_M_FIELD_NUMBER: _ClassVar[int]
    Y_M_FIELD_NUMBER: _ClassVar[int]
    HEADING_RAD_FIELD_NUMBER: _ClassVar[int]
    timestamp_s: float
    position_m: float
    x_m: float
    y_m: float
    heading_rad: float
    def __init__(self, timestamp_s: _Optional[float] = ..., position_m: _Optional[float] = ..., x_m: _Optional[float] = ..., y_m: _Optional[float] = ..., heading_rad: _Optional[float] = ...) -> None: ...

class Track(_message.Message):
    __slots__ = ("name", "cone_x_m", "cone_y_m", "colours", "sizes", "centreline", "left", "right", "width_m", "is_loop", "lap_length_m")
    NAME_FIELD_NUMBER: _ClassVar[int]
    CONE_X_M_FIELD_NUMBER: _ClassVar[int]
    CONE_Y_M_FIELD_NUMBER: _ClassVar[int]
    COLOURS_FIELD_NUMBER: _ClassVar[int]
    SIZES_FIELD_NUMBER: _ClassVar[int]
    CENTRELINE_FIELD_NUMBER: _ClassVar[int]
    LEFT_FIELD_NUMBER: _ClassVar[int]
    RIGHT_FIELD_NUMBER: _ClassVar[int]
    WIDTH_M_FIELD_NUMBER: _ClassVar[int]
    IS_LOOP_FIELD_NUMBER: _ClassVar[int]
    LAP_LENGTH_M_FIELD_NUMBER: _ClassVar[int]
    name: str
    cone_x_m: _containers.RepeatedScalarFieldContainer[float]
    cone_y_m: _containers.RepeatedScalarFieldContainer[float]
    colours: _containers.RepeatedScalarFieldContainer[ConeColour]
    sizes: _containers.RepeatedScalarFieldContainer[ConeSize]
    centreline: Path2D
    left: Path2D
    right: Path2D
    width_m: float
    is_loop: bool
    lap_length_m: float
    def __init__(self, name: _Optional[str] = ..., cone_x_m: _Optional[_Iterable[float]] = ..., cone_y_m: _Optional[_Iterable[float]] = ..., colours: _Optional[_Iterable[_Union[ConeColour, str]]] = ..., sizes: _Optional[_Iterable[_Union[ConeSize, str]]] = ..., centreline: _Optional[_Union[Path2D, _Mapping]] = ..., left: _Optional[_Union[Path2D, _Mapping]] = ..., right: _Optional[_Union[Path2D, _Mapping]] = ..., width_m: _Optional[float] = ..., is_loop: _Optional[bool] = ..., lap_length_m: _Optional[float] = ...) -> None: ...
