"""Topic names of a recording and the message type each carries.

Raw sensor units (what replay feeds back through the parsers), the stack's outputs, simulation
ground truth, and two derived topics in Foxglove's own schemas so that a recording opens in
Foxglove with no setup.
"""

from __future__ import annotations

from common.messages import (
    ActuatorCommand,
    CanFrame,
    GroundTruth,
    Health,
    MapState,
    Plan,
    RawBytes,
)
from common.track import TrackLayout

# Raw units
GPS_NMEA = "/gps/nmea"
IMU_PACKET = "/imu/packet"
CAN_FRAME = "/can/frame"
LIDAR_PACKET = "/lidar/packet"
CAMERA_PACKET = "/camera/packet"

# Outputs of the stack
MAP_STATE = "/map/state"
PLAN = "/plan"
COMMAND = "/command"
HEALTH = "/health"

# Simulation only
TRUTH_POSE = "/truth/pose"
TRUTH_TRACK = "/truth/track"
EVAL_POSE_ERROR = "/eval/pose_error"
"""The estimated pose against the truth (``fsd.PoseError``), for plots; derived, not replayed."""

# Foxglove views (derived; not replayed)
FOXGLOVE_SCENE = "/foxglove/scene"
FOXGLOVE_GPS = "/foxglove/gps"
FOXGLOVE_TF = "/foxglove/tf"

#: Topic of each raw source (``RawBytes.source``); CAN frames go to :data:`CAN_FRAME`.
RAW_TOPIC_BY_SOURCE: dict[str, str] = {
    "gps": GPS_NMEA,
    "imu": IMU_PACKET,
    "lidar": LIDAR_PACKET,
    "camera": CAMERA_PACKET,
}

RAW_TOPICS: tuple[str, ...] = (GPS_NMEA, IMU_PACKET, CAN_FRAME, LIDAR_PACKET, CAMERA_PACKET)
OUTPUT_TOPICS: tuple[str, ...] = (MAP_STATE, PLAN, COMMAND, HEALTH)
TRUTH_TOPICS: tuple[str, ...] = (TRUTH_POSE, TRUTH_TRACK)
FOXGLOVE_TOPICS: tuple[str, ...] = (FOXGLOVE_SCENE, FOXGLOVE_GPS, FOXGLOVE_TF)
DERIVED_TOPICS: tuple[str, ...] = (*FOXGLOVE_TOPICS, EVAL_POSE_ERROR)
"""Topics made from others for viewing: a replay does not read them."""

#: Message type on each known topic (Foxglove topics carry protobuf messages as they are).
TOPIC_TYPES: dict[str, type] = {
    GPS_NMEA: RawBytes,
    IMU_PACKET: RawBytes,
    CAN_FRAME: CanFrame,
    LIDAR_PACKET: RawBytes,
    CAMERA_PACKET: RawBytes,
    MAP_STATE: MapState,
    PLAN: Plan,
    COMMAND: ActuatorCommand,
    HEALTH: Health,
    TRUTH_POSE: GroundTruth,
    TRUTH_TRACK: TrackLayout,
}

#: Protobuf schema name on each Foxglove topic.
FOXGLOVE_SCHEMAS: dict[str, str] = {
    FOXGLOVE_SCENE: "foxglove.SceneUpdate",
    FOXGLOVE_GPS: "foxglove.LocationFix",
    FOXGLOVE_TF: "foxglove.FrameTransform",
}


def raw_topic(raw: RawBytes | CanFrame) -> str:
    """The topic a raw unit is recorded on (``/raw/<source>`` for an unknown source)."""
    if isinstance(raw, CanFrame):
        return CAN_FRAME
    return RAW_TOPIC_BY_SOURCE.get(raw.source, f"/raw/{raw.source}")
