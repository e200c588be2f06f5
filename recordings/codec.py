"""Conversion between :mod:`common.messages` types and the protobuf messages of ``fsd.proto``.

:func:`to_proto` and :func:`from_proto` are exact inverses for every message type: floats are
stored as doubles (NaN, infinities and signed zeros survive), arrays keep their shapes and
dtypes, enums come back as the :mod:`common.messages` enums.

The simulated track is not a :mod:`common.messages` type (it lives in ``simulator.tracks``, which
this package must not import); :func:`to_proto` accepts any object with the track's attributes
and :func:`from_proto` returns a :class:`TrackRecord` holding the same fields.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
from google.protobuf.message import Message as ProtoMessage

from common.errors import RecordingError
from common.messages import (
    ActuatorCommand,
    AsState,
    Baseframe,
    CameraCones,
    CanFrame,
    ConeColour,
    ConeDetection,
    ConeMap,
    ConeSize,
    FloatArray,
    GpsFix,
    GroundTruth,
    Health,
    ImuSample,
    IntArray,
    LidarCones,
    LidarPoints,
    MapState,
    Plan,
    PoseEstimate,
    RawBytes,
    RemoteStop,
    SourceHealth,
    SteeringAngle,
    TargetStates,
    WheelSpeeds,
)
from recordings import fsd_pb2 as pb


class TrackLike(Protocol):
    """What :func:`to_proto` needs of a track (``simulator.tracks.Track`` has it)."""

    name: str
    cones_xy_m: Any
    colours: Any
    sizes: Any
    centreline_xy_m: Any
    left_xy_m: Any
    right_xy_m: Any
    width_m: float
    is_loop: bool
    lap_length_m: float


@dataclass(frozen=True, slots=True, eq=False)
class TrackRecord:
    """A recorded track, in the world frame: the fields of ``simulator.tracks.Track``.

    ``cones_xy_m`` (N, 2); ``colours`` / ``sizes`` (N,) :class:`ConeColour` / :class:`ConeSize`
    values; ``centreline_xy_m`` (M, 2); ``left_xy_m`` / ``right_xy_m`` (L, 2) / (R, 2).
    """

    name: str
    cones_xy_m: FloatArray
    colours: IntArray
    sizes: IntArray
    centreline_xy_m: FloatArray
    left_xy_m: FloatArray
    right_xy_m: FloatArray
    width_m: float
    is_loop: bool
    lap_length_m: float


# ---------------------------------------------------------------------------------------------
# Helpers
# ---------------------------------------------------------------------------------------------


def _floats(values: Any) -> list[float]:
    return np.asarray(values, dtype=np.float64).ravel().tolist()  # type: ignore[no-any-return]


def _ints(values: Any) -> list[int]:
    return np.asarray(values, dtype=np.int64).ravel().tolist()  # type: ignore[no-any-return]


def _array(values: Any, shape: tuple[int, ...] | None = None) -> FloatArray:
    array = np.array(values, dtype=np.float64)
    return array.reshape(shape) if shape is not None else array


def _int_array(values: Any) -> IntArray:
    return np.array(values, dtype=np.int64)


def _xy(path: Any) -> pb.Path2D:
    xy = np.asarray(path, dtype=np.float64).reshape(-1, 2)
    return pb.Path2D(x_m=xy[:, 0].tolist(), y_m=xy[:, 1].tolist())


def _from_xy(path: pb.Path2D) -> FloatArray:
    if len(path.x_m) != len(path.y_m):
        raise RecordingError(f"Path2D has {len(path.x_m)} x and {len(path.y_m)} y values")
    xy = np.empty((len(path.x_m), 2), dtype=np.float64)
    xy[:, 0] = path.x_m
    xy[:, 1] = path.y_m
    return xy


def _enum(enum_type: type[Any], value: int) -> Any:
    """``enum_type(value)``, keeping unknown numbers (from a newer writer) as plain ints."""
    try:
        return enum_type(value)
    except ValueError:
        return int(value)


# ---------------------------------------------------------------------------------------------
# Messages to protobuf
# ---------------------------------------------------------------------------------------------


def _flat_to(proto_type: type) -> Callable[[Any], ProtoMessage]:
    """A converter to ``proto_type`` for a flat message dataclass (all fields scalars, named as
    in fsd.proto: GpsFix, ImuSample, WheelSpeeds, SteeringAngle, RemoteStop, GroundTruth)."""

    def convert(m: Any) -> ProtoMessage:
        return proto_type(**{f.name: getattr(m, f.name) for f in dataclasses.fields(m)})

    return convert


def _flat_back(message_type: type) -> Callable[[Any], Any]:
    """A converter from the proto back to the flat message dataclass ``message_type``."""
    names = [f.name for f in dataclasses.fields(message_type)]

    def convert(p: Any) -> Any:
        return message_type(**{name: getattr(p, name) for name in names})

    return convert


def _raw_bytes(m: RawBytes) -> pb.RawBytes:
    return pb.RawBytes(timestamp_s=m.timestamp_s, source=m.source, payload=bytes(m.payload))


def _can_frame(m: CanFrame) -> pb.CanFrame:
    return pb.CanFrame(
        timestamp_s=m.timestamp_s,
        arbitration_id=m.arbitration_id,
        data=bytes(m.data),
        is_extended_id=m.is_extended_id,
    )












def _cone(m: ConeDetection) -> pb.ConeDetection:
    return pb.ConeDetection(
        timestamp_s=m.timestamp_s,
        x_m=m.x_m,
        y_m=m.y_m,
        colour=int(m.colour),  # type: ignore[arg-type]
        size=int(m.size),  # type: ignore[arg-type]
        confidence=m.confidence,
        height_m=m.height_m,
        width_m=m.width_m,
    )


def _lidar_cones(m: LidarCones) -> pb.LidarCones:
    return pb.LidarCones(
        timestamp_s=m.timestamp_s,
        cones=[_cone(c) for c in m.cones],
        sweep_start_s=m.sweep_start_s,
        point_count=m.point_count,
    )


def _camera_cones(m: CameraCones) -> pb.CameraCones:
    return pb.CameraCones(
        timestamp_s=m.timestamp_s, cones=[_cone(c) for c in m.cones], frame_id=m.frame_id
    )


def _lidar_points(m: LidarPoints) -> pb.LidarPoints:
    return pb.LidarPoints(
        timestamp_s=m.timestamp_s,
        points=_floats(m.points),
        times_s=_floats(m.times_s),
        rings=_ints(m.rings),
        return_count=m.return_count,
        start_s=m.start_s,
    )


def _pose(m: PoseEstimate) -> pb.PoseEstimate:
    return pb.PoseEstimate(
        timestamp_s=m.timestamp_s,
        x_m=m.x_m,
        y_m=m.y_m,
        yaw_rad=m.yaw_rad,
        vx_mps=m.vx_mps,
        vy_mps=m.vy_mps,
        yaw_rate_radps=m.yaw_rate_radps,
        covariance=_floats(m.covariance),
    )


def _cone_map(m: ConeMap) -> pb.ConeMap:
    return pb.ConeMap(
        x_m=m.xy_m[:, 0].tolist(),
        y_m=m.xy_m[:, 1].tolist(),
        covariance=_floats(m.covariance),
        colour=_ints(m.colour),  # type: ignore[arg-type]
        size=_ints(m.size),  # type: ignore[arg-type]
        confidence=_floats(m.confidence),
        ids=_ints(m.ids),
    )


def _map_state(m: MapState) -> pb.MapState:
    return pb.MapState(
        timestamp_s=m.timestamp_s,
        pose=_pose(m.pose),
        cones=_cone_map(m.cones),
        loop_closed=m.loop_closed,
        backend=m.backend,
        map_frozen=m.map_frozen,
    )


def _baseframe(m: Baseframe) -> pb.Baseframe:
    return pb.Baseframe(
        s_m=_floats(m.s_m),
        x_m=_floats(m.x_m),
        y_m=_floats(m.y_m),
        heading_rad=_floats(m.heading_rad),
        curvature_1pm=_floats(m.curvature_1pm),
        closed=m.closed,
        length_m=m.length_m,
    )


def _target_states(m: TargetStates) -> pb.TargetStates:
    return pb.TargetStates(
        t_s=_floats(m.t_s),
        x_m=_floats(m.x_m),
        y_m=_floats(m.y_m),
        yaw_rad=_floats(m.yaw_rad),
        speed_mps=_floats(m.speed_mps),
        curvature_1pm=_floats(m.curvature_1pm),
    )


def _plan(m: Plan) -> pb.Plan:
    proto = pb.Plan(
        timestamp_s=m.timestamp_s,
        manoeuvre=_target_states(m.manoeuvre),
        target_speed_mps=m.target_speed_mps,
        candidates=[_xy(c) for c in m.candidates],
        chosen_index=m.chosen_index,
        waypoints=_xy(m.waypoints_xy_m),
        lap=m.lap,
    )
    if m.baseframe is not None:
        proto.baseframe.CopyFrom(_baseframe(m.baseframe))
    return proto


def _command(m: ActuatorCommand) -> pb.ActuatorCommand:
    return pb.ActuatorCommand(
        timestamp_s=m.timestamp_s,
        throttle=m.throttle,
        brake=m.brake,
        steering_rad=m.steering_rad,
        state=int(m.state),  # type: ignore[arg-type]
    )


def _source_health(m: SourceHealth) -> pb.SourceHealth:
    return pb.SourceHealth(
        timestamp_s=m.timestamp_s,
        source=m.source,
        alive=m.alive,
        rate_hz=m.rate_hz,
        age_s=m.age_s,
        errors=m.errors,
        stale=m.stale,
        rejects=[pb.RejectCount(reason=r, count=c) for r, c in m.rejects],
    )


def _health(m: Health) -> pb.Health:
    return pb.Health(
        timestamp_s=m.timestamp_s,
        sources=[_source_health(s) for s in m.sources],
        state=int(m.state),  # type: ignore[arg-type]
        stop_reason=m.stop_reason,
    )




def _track(m: TrackLike) -> pb.Track:
    cones = np.asarray(m.cones_xy_m, dtype=np.float64).reshape(-1, 2)
    return pb.Track(
        name=str(m.name),
        cone_x_m=cones[:, 0].tolist(),
        cone_y_m=cones[:, 1].tolist(),
        colours=_ints(m.colours),  # type: ignore[arg-type]
        sizes=_ints(m.sizes),  # type: ignore[arg-type]
        centreline=_xy(m.centreline_xy_m),
        left=_xy(m.left_xy_m),
        right=_xy(m.right_xy_m),
        width_m=float(m.width_m),
        is_loop=bool(m.is_loop),
        lap_length_m=float(m.lap_length_m),
    )


_TO_PROTO: dict[type, Callable[[Any], ProtoMessage]] = {
    RawBytes: _raw_bytes,
    CanFrame: _can_frame,
    GpsFix: _flat_to(pb.GpsFix),
    ImuSample: _flat_to(pb.ImuSample),
    WheelSpeeds: _flat_to(pb.WheelSpeeds),
    SteeringAngle: _flat_to(pb.SteeringAngle),
    RemoteStop: _flat_to(pb.RemoteStop),
    ConeDetection: _cone,
    LidarCones: _lidar_cones,
    CameraCones: _camera_cones,
    LidarPoints: _lidar_points,
    PoseEstimate: _pose,
    ConeMap: _cone_map,
    MapState: _map_state,
    Baseframe: _baseframe,
    TargetStates: _target_states,
    Plan: _plan,
    ActuatorCommand: _command,
    SourceHealth: _source_health,
    Health: _health,
    GroundTruth: _flat_to(pb.GroundTruth),
    TrackRecord: _track,
}

_TRACK_FIELDS = ("cones_xy_m", "colours", "sizes", "centreline_xy_m", "is_loop", "lap_length_m")


def is_track(message: object) -> bool:
    """True for a track (``simulator.tracks.Track`` or :class:`TrackRecord`)."""
    return all(hasattr(message, name) for name in _TRACK_FIELDS)


def to_proto(message: object) -> ProtoMessage:
    """The ``fsd.proto`` message for a :mod:`common.messages` object (or a track).

    Raises :class:`RecordingError` for a type that has no schema.
    """
    convert = _TO_PROTO.get(type(message))
    if convert is not None:
        return convert(message)
    if is_track(message):
        return _track(message)  # type: ignore[arg-type]
    raise RecordingError(f"no recording schema for {type(message).__name__}")


# ---------------------------------------------------------------------------------------------
# Protobuf to messages
# ---------------------------------------------------------------------------------------------


def _raw_bytes_back(p: pb.RawBytes) -> RawBytes:
    return RawBytes(p.timestamp_s, p.source, bytes(p.payload))


def _can_frame_back(p: pb.CanFrame) -> CanFrame:
    return CanFrame(p.timestamp_s, p.arbitration_id, bytes(p.data), p.is_extended_id)












def _cone_back(p: pb.ConeDetection) -> ConeDetection:
    return ConeDetection(
        timestamp_s=p.timestamp_s,
        x_m=p.x_m,
        y_m=p.y_m,
        colour=_enum(ConeColour, p.colour),
        size=_enum(ConeSize, p.size),
        confidence=p.confidence,
        height_m=p.height_m,
        width_m=p.width_m,
    )


def _lidar_cones_back(p: pb.LidarCones) -> LidarCones:
    return LidarCones(
        timestamp_s=p.timestamp_s,
        cones=tuple(_cone_back(c) for c in p.cones),
        sweep_start_s=p.sweep_start_s,
        point_count=p.point_count,
    )


def _camera_cones_back(p: pb.CameraCones) -> CameraCones:
    return CameraCones(
        timestamp_s=p.timestamp_s, cones=tuple(_cone_back(c) for c in p.cones), frame_id=p.frame_id
    )


def _lidar_points_back(p: pb.LidarPoints) -> LidarPoints:
    return LidarPoints(
        timestamp_s=p.timestamp_s,
        points=_array(p.points, (-1, 4)),
        times_s=_array(p.times_s),
        rings=_int_array(p.rings),
        return_count=p.return_count,
        start_s=p.start_s,
    )


def _pose_back(p: pb.PoseEstimate) -> PoseEstimate:
    cov = _array(p.covariance)
    return PoseEstimate(
        timestamp_s=p.timestamp_s,
        x_m=p.x_m,
        y_m=p.y_m,
        yaw_rad=p.yaw_rad,
        vx_mps=p.vx_mps,
        vy_mps=p.vy_mps,
        yaw_rate_radps=p.yaw_rate_radps,
        covariance=cov.reshape(3, 3) if cov.size == 9 else np.zeros((3, 3)),
    )


def _cone_map_back(p: pb.ConeMap) -> ConeMap:
    n = len(p.x_m)
    xy = np.empty((n, 2), dtype=np.float64)
    xy[:, 0] = p.x_m
    xy[:, 1] = p.y_m if len(p.y_m) == n else math.nan
    try:
        return ConeMap(
            xy_m=xy,
            covariance=_array(p.covariance),
            colour=_int_array(p.colour),
            size=_int_array(p.size),
            confidence=_array(p.confidence),
            ids=_int_array(p.ids),
        )
    except ValueError as exc:
        raise RecordingError(f"inconsistent ConeMap in recording: {exc}") from exc


def _map_state_back(p: pb.MapState) -> MapState:
    return MapState(
        timestamp_s=p.timestamp_s,
        pose=_pose_back(p.pose),
        cones=_cone_map_back(p.cones),
        loop_closed=p.loop_closed,
        backend=p.backend,
        map_frozen=p.map_frozen,
    )


def _baseframe_back(p: pb.Baseframe) -> Baseframe:
    return Baseframe(
        s_m=_array(p.s_m),
        x_m=_array(p.x_m),
        y_m=_array(p.y_m),
        heading_rad=_array(p.heading_rad),
        curvature_1pm=_array(p.curvature_1pm),
        closed=p.closed,
        length_m=p.length_m,
    )


def _target_states_back(p: pb.TargetStates) -> TargetStates:
    return TargetStates(
        t_s=_array(p.t_s),
        x_m=_array(p.x_m),
        y_m=_array(p.y_m),
        yaw_rad=_array(p.yaw_rad),
        speed_mps=_array(p.speed_mps),
        curvature_1pm=_array(p.curvature_1pm),
    )


def _plan_back(p: pb.Plan) -> Plan:
    return Plan(
        timestamp_s=p.timestamp_s,
        baseframe=_baseframe_back(p.baseframe) if p.HasField("baseframe") else None,
        manoeuvre=_target_states_back(p.manoeuvre),
        target_speed_mps=p.target_speed_mps,
        candidates=tuple(_from_xy(c) for c in p.candidates),
        chosen_index=p.chosen_index,
        waypoints_xy_m=_from_xy(p.waypoints),
        lap=p.lap,
    )


def _command_back(p: pb.ActuatorCommand) -> ActuatorCommand:
    try:
        return ActuatorCommand(
            p.timestamp_s, p.throttle, p.brake, p.steering_rad, _enum(AsState, p.state)
        )
    except ValueError as exc:
        raise RecordingError(f"invalid ActuatorCommand in recording: {exc}") from exc


def _source_health_back(p: pb.SourceHealth) -> SourceHealth:
    return SourceHealth(
        timestamp_s=p.timestamp_s,
        source=p.source,
        alive=p.alive,
        rate_hz=p.rate_hz,
        age_s=p.age_s,
        errors=p.errors,
        stale=p.stale,
        rejects=tuple((r.reason, r.count) for r in p.rejects),
    )


def _health_back(p: pb.Health) -> Health:
    return Health(
        timestamp_s=p.timestamp_s,
        sources=tuple(_source_health_back(s) for s in p.sources),
        state=_enum(AsState, p.state),
        stop_reason=p.stop_reason,
    )




def _track_back(p: pb.Track) -> TrackRecord:
    n = len(p.cone_x_m)
    cones = np.empty((n, 2), dtype=np.float64)
    cones[:, 0] = p.cone_x_m
    cones[:, 1] = p.cone_y_m if len(p.cone_y_m) == n else math.nan
    return TrackRecord(
        name=p.name,
        cones_xy_m=cones,
        colours=_int_array(p.colours),
        sizes=_int_array(p.sizes),
        centreline_xy_m=_from_xy(p.centreline),
        left_xy_m=_from_xy(p.left),
        right_xy_m=_from_xy(p.right),
        width_m=p.width_m,
        is_loop=p.is_loop,
        lap_length_m=p.lap_length_m,
    )


_FROM_PROTO: dict[type, Callable[[Any], object]] = {
    pb.RawBytes: _raw_bytes_back,
    pb.CanFrame: _can_frame_back,
    pb.GpsFix: _flat_back(GpsFix),
    pb.ImuSample: _flat_back(ImuSample),
    pb.WheelSpeeds: _flat_back(WheelSpeeds),
    pb.SteeringAngle: _flat_back(SteeringAngle),
    pb.RemoteStop: _flat_back(RemoteStop),
    pb.ConeDetection: _cone_back,
    pb.LidarCones: _lidar_cones_back,
    pb.CameraCones: _camera_cones_back,
    pb.LidarPoints: _lidar_points_back,
    pb.PoseEstimate: _pose_back,
    pb.ConeMap: _cone_map_back,
    pb.MapState: _map_state_back,
    pb.Baseframe: _baseframe_back,
    pb.TargetStates: _target_states_back,
    pb.Plan: _plan_back,
    pb.ActuatorCommand: _command_back,
    pb.SourceHealth: _source_health_back,
    pb.Health: _health_back,
    pb.GroundTruth: _flat_back(GroundTruth),
    pb.Track: _track_back,
}

#: Protobuf classes of ``fsd.proto`` by full schema name (``"fsd.MapState"``).
PROTO_CLASSES: dict[str, type[ProtoMessage]] = {
    cls.DESCRIPTOR.full_name: cls for cls in _FROM_PROTO  # type: ignore[attr-defined]
}


def from_proto(proto: ProtoMessage) -> object:
    """The :mod:`common.messages` object (or :class:`TrackRecord`) for an ``fsd.proto`` message.

    Raises :class:`RecordingError` for a message that is not of ``fsd.proto`` or whose content
    cannot form a valid message (e.g. a command with throttle and brake both on).
    """
    convert = _FROM_PROTO.get(type(proto))
    if convert is None:
        raise RecordingError(f"no message type for protobuf {proto.DESCRIPTOR.full_name}")
    try:
        return convert(proto)
    except (ValueError, TypeError, IndexError, OverflowError) as exc:
        # a field that cannot hold what the message type needs (a LidarPoints whose point
        # values are not a multiple of 4, an enum value out of range, ...)
        raise RecordingError(f"a {proto.DESCRIPTOR.full_name} that does not form a valid "
                             f"message: {exc}") from exc

