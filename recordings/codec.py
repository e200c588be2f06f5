"""Conversion between the message dataclasses and the protobuf messages of ``fsd.proto``.

One table (:data:`SCHEMAS`) pairs each dataclass with its protobuf message; the fields are
matched by name and converted by their declared types: scalars as they are, enums as their
numbers (unknown numbers from a newer writer come back as plain ints), nested messages and
tuples of them recursively, tuples of tuples as repeated messages of their fields in order.
Arrays are the one thing the table spells out where the names alone do not say it: an (N, 2)
array stored as two columns or as ``Path2D`` messages, and the shape a flattened array comes
back in.

:func:`to_proto` and :func:`from_proto` are exact inverses for every type: floats are stored
as doubles (NaN, infinities and signed zeros survive), arrays keep their shapes and dtypes.
"""

from __future__ import annotations

import dataclasses
import enum
import math
import types
import typing
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from google.protobuf.descriptor import FieldDescriptor
from google.protobuf.message import Message as ProtoMessage

from common.errors import RecordingError
from common.messages import (
    ActuatorCommand,
    Baseframe,
    CameraCones,
    CanFrame,
    ConeDetection,
    ConeMap,
    GpsFix,
    GroundTruth,
    Health,
    ImuSample,
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
from common.track import TrackLayout
from recordings import fsd_pb2 as pb


@dataclass(frozen=True)
class Schema:
    """A dataclass's protobuf message and how its arrays are stored there.

    ``columns``: an (N, 2) array field stored as two repeated fields (x, y); ``paths``: an
    (N, 2) array field, or a tuple of them, stored as ``Path2D`` message(s) in the named field;
    ``shapes``: the shape a flattened array field comes back in (a fixed shape missing or of the
    wrong size comes back as zeros). Other arrays are stored flat and come back flat.
    """

    proto: type[ProtoMessage]
    columns: Mapping[str, tuple[str, str]] = field(default_factory=dict)
    paths: Mapping[str, str] = field(default_factory=dict)
    shapes: Mapping[str, tuple[int, ...]] = field(default_factory=dict)


SCHEMAS: dict[type, Schema] = {
    RawBytes: Schema(pb.RawBytes),
    CanFrame: Schema(pb.CanFrame),
    GpsFix: Schema(pb.GpsFix),
    ImuSample: Schema(pb.ImuSample),
    WheelSpeeds: Schema(pb.WheelSpeeds),
    SteeringAngle: Schema(pb.SteeringAngle),
    RemoteStop: Schema(pb.RemoteStop),
    ConeDetection: Schema(pb.ConeDetection),
    LidarCones: Schema(pb.LidarCones),
    CameraCones: Schema(pb.CameraCones),
    LidarPoints: Schema(pb.LidarPoints, shapes={"points": (-1, 4)}),
    PoseEstimate: Schema(pb.PoseEstimate, shapes={"covariance": (3, 3)}),
    ConeMap: Schema(pb.ConeMap, columns={"xy_m": ("x_m", "y_m")}),
    MapState: Schema(pb.MapState),
    Baseframe: Schema(pb.Baseframe),
    TargetStates: Schema(pb.TargetStates),
    Plan: Schema(pb.Plan, paths={"waypoints_xy_m": "waypoints", "candidates": "candidates"}),
    ActuatorCommand: Schema(pb.ActuatorCommand),
    SourceHealth: Schema(pb.SourceHealth),
    Health: Schema(pb.Health),
    GroundTruth: Schema(pb.GroundTruth),
    TrackLayout: Schema(pb.Track, columns={"cones_xy_m": ("cone_x_m", "cone_y_m")},
                        paths={"centreline_xy_m": "centreline", "left_xy_m": "left",
                               "right_xy_m": "right"}),
}
"""Every recordable dataclass and its ``fsd.proto`` message."""

#: Protobuf classes of ``fsd.proto`` by full schema name (``"fsd.MapState"``).
PROTO_CLASSES: dict[str, type[ProtoMessage]] = {
    schema.proto.DESCRIPTOR.full_name: schema.proto  # type: ignore[attr-defined]
    for schema in SCHEMAS.values()
}

_INT_TYPES = {FieldDescriptor.TYPE_INT32, FieldDescriptor.TYPE_INT64, FieldDescriptor.TYPE_UINT32,
              FieldDescriptor.TYPE_UINT64, FieldDescriptor.TYPE_SINT32,
              FieldDescriptor.TYPE_SINT64, FieldDescriptor.TYPE_ENUM}


def _floats(values: Any) -> list[float]:
    return np.asarray(values, dtype=np.float64).ravel().tolist()  # type: ignore[no-any-return]


def _ints(values: Any) -> list[int]:
    return np.asarray(values, dtype=np.int64).ravel().tolist()  # type: ignore[no-any-return]


def _path(xy: Any) -> pb.Path2D:
    xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    return pb.Path2D(x_m=xy[:, 0].tolist(), y_m=xy[:, 1].tolist())


def _from_path(path: pb.Path2D) -> np.ndarray:
    if len(path.x_m) != len(path.y_m):
        raise RecordingError(f"Path2D has {len(path.x_m)} x and {len(path.y_m)} y values")
    return _from_columns(path.x_m, path.y_m)


def _from_columns(x: Any, y: Any) -> np.ndarray:
    """(N, 2) from N x values and the y values (NaN when there are not N of them)."""
    xy = np.empty((len(x), 2), dtype=np.float64)
    xy[:, 0] = x
    xy[:, 1] = y if len(y) == len(x) else math.nan
    return xy


def _enum(enum_type: type[Any], value: int) -> Any:
    """``enum_type(value)``, keeping unknown numbers (from a newer writer) as plain ints."""
    try:
        return enum_type(value)
    except ValueError:
        return int(value)


# ---------------------------------------------------------------------------------------------
# Field converters, built once per type from the dataclass's type hints and the schema
# ---------------------------------------------------------------------------------------------

ToField = Callable[[Any, dict[str, Any]], None]
"""Puts one dataclass field's value into the protobuf constructor's keyword arguments."""
FromField = Callable[[Any], Any]
"""One dataclass field's value from the protobuf message."""


def _dataclass_of(hint: Any) -> type | None:
    """The dataclass of ``hint`` (also of ``X | None``), or None."""
    if isinstance(hint, type) and dataclasses.is_dataclass(hint):
        return hint
    if typing.get_origin(hint) in (types.UnionType, typing.Union):
        for arg in typing.get_args(hint):
            if arg is not type(None) and (found := _dataclass_of(arg)) is not None:
                return found
    return None


def _converters(cls: type, schema: Schema) -> list[tuple[ToField, FromField, str]]:
    descriptor = schema.proto.DESCRIPTOR  # type: ignore[attr-defined]
    hints = typing.get_type_hints(cls)
    out = []
    for f in dataclasses.fields(cls):
        if f.init:
            out.append((*_field_converter(f.name, hints[f.name], schema, descriptor), f.name))
    return out


def _field_converter(name: str, hint: Any, schema: Schema,
                     descriptor: Any) -> tuple[ToField, FromField]:
    if name in schema.columns:
        xn, yn = schema.columns[name]

        def to_columns(v: Any, kw: dict[str, Any]) -> None:
            xy = np.asarray(v, dtype=np.float64).reshape(-1, 2)
            kw[xn], kw[yn] = xy[:, 0].tolist(), xy[:, 1].tolist()

        return to_columns, lambda p: _from_columns(getattr(p, xn), getattr(p, yn))
    if name in schema.paths:
        pn = schema.paths[name]
        if typing.get_origin(hint) is tuple:
            return (lambda v, kw: kw.__setitem__(pn, [_path(c) for c in v]),
                    lambda p: tuple(_from_path(c) for c in getattr(p, pn)))
        return (lambda v, kw: kw.__setitem__(pn, _path(v)),
                lambda p: _from_path(getattr(p, pn)))
    proto_field = descriptor.fields_by_name[name]
    nested = _dataclass_of(hint)
    if nested is not None:
        def to_nested(v: Any, kw: dict[str, Any]) -> None:
            if v is not None:
                kw[name] = to_proto(v)

        def from_nested(p: Any) -> Any:
            if hint is not nested and not p.HasField(name):
                return None
            return from_proto(getattr(p, name))

        return to_nested, from_nested
    if isinstance(hint, type) and issubclass(hint, enum.Enum):
        return (lambda v, kw: kw.__setitem__(name, int(v)),
                lambda p: _enum(hint, getattr(p, name)))
    if typing.get_origin(hint) is tuple:
        item = typing.get_args(hint)[0]
        if _dataclass_of(item) is not None:
            return (lambda v, kw: kw.__setitem__(name, [to_proto(m) for m in v]),
                    lambda p: tuple(from_proto(m) for m in getattr(p, name)))
        item_type = getattr(pb, proto_field.message_type.name)
        item_names = [f.name for f in proto_field.message_type.fields]
        return (lambda v, kw: kw.__setitem__(name, [item_type(**dict(zip(item_names, t,
                                                                          strict=True)))
                                                    for t in v]),
                lambda p: tuple(tuple(getattr(m, n) for n in item_names)
                                for m in getattr(p, name)))
    if proto_field.is_repeated:
        integer = proto_field.type in _INT_TYPES
        shape = schema.shapes.get(name)

        def from_array(p: Any) -> np.ndarray:
            array = np.array(getattr(p, name), dtype=np.int64 if integer else np.float64)
            if shape is None:
                return array
            if -1 not in shape and array.size != math.prod(shape):
                return np.zeros(shape)
            return array.reshape(shape)

        return (lambda v, kw: kw.__setitem__(name, _ints(v) if integer else _floats(v)),
                from_array)
    if proto_field.type == FieldDescriptor.TYPE_BYTES:
        return (lambda v, kw: kw.__setitem__(name, bytes(v)),
                lambda p: bytes(getattr(p, name)))
    return lambda v, kw: kw.__setitem__(name, v), lambda p: getattr(p, name)


_BY_CLASS: dict[type, tuple[Schema, list[tuple[ToField, FromField, str]]]] = {}
_BY_PROTO: dict[type, type] = {schema.proto: cls for cls, schema in SCHEMAS.items()}


def _compiled(cls: type) -> tuple[Schema, list[tuple[ToField, FromField, str]]] | None:
    found = _BY_CLASS.get(cls)
    if found is None:
        for base in cls.__mro__:  # a subclass (the simulator's Track) records as its base
            if base in SCHEMAS:
                found = _BY_CLASS[cls] = SCHEMAS[base], _converters(base, SCHEMAS[base])
                break
    return found


def to_proto(message: object) -> ProtoMessage:
    """The ``fsd.proto`` message for a dataclass of :data:`SCHEMAS` (or a subclass of one).

    Raises :class:`RecordingError` for a type that has no schema.
    """
    compiled = _compiled(type(message))
    if compiled is None:
        raise RecordingError(f"no recording schema for {type(message).__name__}")
    schema, converters = compiled
    kwargs: dict[str, Any] = {}
    for to_field, _, name in converters:
        to_field(getattr(message, name), kwargs)
    return schema.proto(**kwargs)


def from_proto(proto: ProtoMessage) -> object:
    """The dataclass for an ``fsd.proto`` message.

    Raises :class:`RecordingError` for a message that is not of ``fsd.proto`` or whose content
    cannot form a valid message (e.g. a command with throttle and brake both on).
    """
    cls = _BY_PROTO.get(type(proto))
    if cls is None:
        raise RecordingError(f"no message type for protobuf {proto.DESCRIPTOR.full_name}")
    compiled = _compiled(cls)
    assert compiled is not None
    try:
        kwargs = {name: from_field(proto) for _, from_field, name in compiled[1]}
        return cls(**kwargs)
    except (ValueError, TypeError, IndexError, OverflowError) as exc:
        # a field that cannot hold what the message type needs (a LidarPoints whose point
        # values are not a multiple of 4, an enum value out of range, ...)
        raise RecordingError(f"a {proto.DESCRIPTOR.full_name} that does not form a valid "
                             f"message: {exc}") from exc
