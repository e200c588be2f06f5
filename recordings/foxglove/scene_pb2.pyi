import datetime

from google.protobuf import duration_pb2 as _duration_pb2
from google.protobuf import timestamp_pb2 as _timestamp_pb2
from google.protobuf.internal import containers as _containers
from google.protobuf.internal import enum_type_wrapper as _enum_type_wrapper
from google.protobuf import descriptor as _descriptor
from google.protobuf import message as _message
from collections.abc import Iterable as _Iterable, Mapping as _Mapping
from typing import ClassVar as _ClassVar, Optional as _Optional, Union as _Union

DESCRIPTOR: _descriptor.FileDescriptor

class Vector3(_message.Message):
    __slots__ = ("x", "y", "z")
    X_FIELD_NUMBER: _ClassVar[int]
    Y_FIELD_NUMBER: _ClassVar[int]
    Z_FIELD_NUMBER: _ClassVar[int]
    x: float
    y: float
    z: float
    def __init__(self, x: _Optional[float] = ..., y: _Optional[float] = ..., z: _Optional[float] = ...) -> None: ...

class Point3(_message.Message):
    __slots__ = ("x", "y", "z")
    X_FIELD_NUMBER: _ClassVar[int]
    Y_FIELD_NUMBER: _ClassVar[int]
    Z_FIELD_NUMBER: _ClassVar[int]
    x: float
    y: float
    z: float
    def __init__(self, x: _Optional[float] = ..., y: _Optional[float] = ..., z: _Optional[float] = ...) -> None: ...

class Quaternion(_message.Message):
    __slots__ = ("x", "y", "z", "w")
    X_FIELD_NUMBER: _ClassVar[int]
    Y_FIELD_NUMBER: _ClassVar[int]
    Z_FIELD_NUMBER: _ClassVar[int]
    W_FIELD_NUMBER: _ClassVar[int]
    x: float
    y: float
    z: float
    w: float
    def __init__(self, x: _Optional[float] = ..., y: _Optional[float] = ..., z: _Optional[float] = ..., w: _Optional[float] = ...) -> None: ...

class Pose(_message.Message):
    __slots__ = ("position", "orientation")
    POSITION_FIELD_NUMBER: _ClassVar[int]
    ORIENTATION_FIELD_NUMBER: _ClassVar[int]
    position: Vector3
    orientation: Quaternion
    def __init__(self, position: _Optional[_Union[Vector3, _Mapping]] = ..., orientation: _Optional[_Union[Quaternion, _Mapping]] = ...) -> None: ...

class Color(_message.Message):
    __slots__ = ("r", "g", "b", "a")
    R_FIELD_NUMBER: _ClassVar[int]
    G_FIELD_NUMBER: _ClassVar[int]
    B_FIELD_NUMBER: _ClassVar[int]
    A_FIELD_NUMBER: _ClassVar[int]
    r: float
    g: float
    b: float
    a: float
    def __init__(self, r: _Optional[float] = ..., g: _Optional[float] = ..., b: _Optional[float] = ..., a: _Optional[float] = ...) -> None: ...

class KeyValuePair(_message.Message):
    __slots__ = ("key", "value")
    KEY_FIELD_NUMBER: _ClassVar[int]
    VALUE_FIELD_NUMBER: _ClassVar[int]
    key: str
    value: str
    def __init__(self, key: _Optional[str] = ..., value: _Optional[str] = ...) -> None: ...

class ArrowPrimitive(_message.Message):
    __slots__ = ("pose", "shaft_length", "shaft_diameter", "head_length", "head_diameter", "color")
    POSE_FIELD_NUMBER: _ClassVar[int]
    SHAFT_LENGTH_FIELD_NUMBER: _ClassVar[int]
    SHAFT_DIAMETER_FIELD_NUMBER: _ClassVar[int]
    HEAD_LENGTH_FIELD_NUMBER: _ClassVar[int]
    HEAD_DIAMETER_FIELD_NUMBER: _ClassVar[int]
    COLOR_FIELD_NUMBER: _ClassVar[int]
    pose: Pose
    shaft_length: float
    shaft_diameter: float
    head_length: float
    head_diameter: float
    color: Color
    def __init__(self, pose: _Optional[_Union[Pose, _Mapping]] = ..., shaft_length: _Optional[float] = ..., shaft_diameter: _Optional[float] = ..., head_length: _Optional[float] = ..., head_diameter: _Optional[float] = ..., color: _Optional[_Union[Color, _Mapping]] = ...) -> None: ...

class CubePrimitive(_message.Message):
    __slots__ = ("pose", "size", "color")
    POSE_FIELD_NUMBER: _ClassVar[int]
    SIZE_FIELD_NUMBER: _ClassVar[int]
    COLOR_FIELD_NUMBER: _ClassVar[int]
    pose: Pose
    size: Vector3
    color: Color
    def __init__(self, pose: _Optional[_Union[Pose, _Mapping]] = ..., size: _Optional[_Union[Vector3, _Mapping]] = ..., color: _Optional[_Union[Color, _Mapping]] = ...) -> None: ...

class SpherePrimitive(_message.Message):
    __slots__ = ("pose", "size", "color")
    POSE_FIELD_NUMBER: _ClassVar[int]
    SIZE_FIELD_NUMBER: _ClassVar[int]
    COLOR_FIELD_NUMBER: _ClassVar[int]
    pose: Pose
    size: Vector3
    color: Color
    def __init__(self, pose: _Optional[_Union[Pose, _Mapping]] = ..., size: _Optional[_Union[Vector3, _Mapping]] = ..., color: _Optional[_Union[Color, _Mapping]] = ...) -> None: ...

class CylinderPrimitive(_message.Message):
    __slots__ = ("pose", "size", "bottom_scale", "top_scale", "color")
    POSE_FIELD_NUMBER: _ClassVar[int]
    SIZE_FIELD_NUMBER: _ClassVar[int]
    BOTTOM_SCALE_FIELD_NUMBER: _ClassVar[int]
    TOP_SCALE_FIELD_NUMBER: _ClassVar[int]
    COLOR_FIELD_NUMBER: _ClassVar[int]
    pose: Pose
    size: Vector3
    bottom_scale: float
    top_scale: float
    color: Color
    def __init__(self, pose: _Optional[_Union[Pose, _Mapping]] = ..., size: _Optional[_Union[Vector3, _Mapping]] = ..., bottom_scale: _Optional[float] = ..., top_scale: _Optional[float] = ..., color: _Optional[_Union[Color, _Mapping]] = ...) -> None: ...

class LinePrimitive(_message.Message):
    __slots__ = ("type", "pose", "thickness", "scale_invariant", "points", "color", "colors", "indices")
    class Type(int, metaclass=_enum_type_wrapper.EnumTypeWrapper):
        __slots__ = ()
        LINE_STRIP: _ClassVar[LinePrimitive.Type]
        LINE_LOOP: _ClassVar[LinePrimitive.Type]
        LINE_LIST: _ClassVar[LinePrimitive.Type]
    LINE_STRIP: LinePrimitive.Type
    LINE_LOOP: LinePrimitive.Type
    LINE_LIST: LinePrimitive.Type
    TYPE_FIELD_NUMBER: _ClassVar[int]
    POSE_FIELD_NUMBER: _ClassVar[int]
    THICKNESS_FIELD_NUMBER: _ClassVar[int]
    SCALE_INVARIANT_FIELD_NUMBER: _ClassVar[int]
    POINTS_FIELD_NUMBER: _ClassVar[int]
    COLOR_FIELD_NUMBER: _ClassVar[int]
    COLORS_FIELD_NUMBER: _ClassVar[int]
    INDICES_FIELD_NUMBER: _ClassVar[int]
    type: LinePrimitive.Type
    pose: Pose
    thickness: float
    scale_invariant: bool
    points: _containers.RepeatedCompositeFieldContainer[Point3]
    color: Color
    colors: _containers.RepeatedCompositeFieldContainer[Color]
    indices: _containers.RepeatedScalarFieldContainer[int]
    def __init__(self, type: _Optional[_Union[LinePrimitive.Type, str]] = ..., pose: _Optional[_Union[Pose, _Mapping]] = ..., thickness: _Optional[float] = ..., scale_invariant: _Optional[bool] = ..., points: _Optional[_Iterable[_Union[Point3, _Mapping]]] = ..., color: _Optional[_Union[Color, _Mapping]] = ..., colors: _Optional[_Iterable[_Union[Color, _Mapping]]] = ..., indices: _Optional[_Iterable[int]] = ...) -> None: ...

class TriangleListPrimitive(_message.Message):
    __slots__ = ("pose", "points", "color", "colors", "indices")
    POSE_FIELD_NUMBER: _ClassVar[int]
    POINTS_FIELD_NUMBER: _ClassVar[int]
    COLOR_FIELD_NUMBER: _ClassVar[int]
    COLORS_FIELD_NUMBER: _ClassVar[int]
    INDICES_FIELD_NUMBER: _ClassVar[int]
    pose: Pose
    points: _containers.RepeatedCompositeFieldContainer[Point3]
    color: Color
    colors: _containers.RepeatedCompositeFieldContainer[Color]
    indices: _containers.RepeatedScalarFieldContainer[int]
    def __init__(self, pose: _Optional[_Union[Pose, _Mapping]] = ..., points: _Optional[_Iterable[_Union[Point3, _Mapping]]] = ..., color: _Optional[_Union[Color, _Mapping]] = ..., colors: _Optional[_Iterable[_Union[Color, _Mapping]]] = ..., indices: _Optional[_Iterable[int]] = ...) -> None: ...

class TextPrimitive(_message.Message):
    __slots__ = ("pose", "billboard", "font_size", "scale_invariant", "color", "text")
    POSE_FIELD_NUMBER: _ClassVar[int]
    BILLBOARD_FIELD_NUMBER: _ClassVar[int]
    FONT_SIZE_FIELD_NUMBER: _ClassVar[int]
    SCALE_INVARIANT_FIELD_NUMBER: _ClassVar[int]
    COLOR_FIELD_NUMBER: _ClassVar[int]
    TEXT_FIELD_NUMBER: _ClassVar[int]
    pose: Pose
    billboard: bool
    font_size: float
    scale_invariant: bool
    color: Color
    text: str
    def __init__(self, pose: _Optional[_Union[Pose, _Mapping]] = ..., billboard: _Optional[bool] = ..., font_size: _Optional[float] = ..., scale_invariant: _Optional[bool] = ..., color: _Optional[_Union[Color, _Mapping]] = ..., text: _Optional[str] = ...) -> None: ...

class ModelPrimitive(_message.Message):
    __slots__ = ("pose", "scale", "color", "override_color", "url", "media_type", "data")
    POSE_FIELD_NUMBER: _ClassVar[int]
    SCALE_FIELD_NUMBER: _ClassVar[int]
    COLOR_FIELD_NUMBER: _ClassVar[int]
    OVERRIDE_COLOR_FIELD_NUMBER: _ClassVar[int]
    URL_FIELD_NUMBER: _ClassVar[int]
    MEDIA_TYPE_FIELD_NUMBER: _ClassVar[int]
    DATA_FIELD_NUMBER: _ClassVar[int]
    pose: Pose
    scale: Vector3
    color: Color
    override_color: bool
    url: str
    media_type: str
    data: bytes
    def __init__(self, pose: _Optional[_Union[Pose, _Mapping]] = ..., scale: _Optional[_Union[Vector3, _Mapping]] = ..., color: _Optional[_Union[Color, _Mapping]] = ..., override_color: _Optional[bool] = ..., url: _Optional[str] = ..., media_type: _Optional[str] = ..., data: _Optional[bytes] = ...) -> None: ...

class SceneEntity(_message.Message):
    __slots__ = ("timestamp", "frame_id", "id", "lifetime", "frame_locked", "metadata", "arrows", "cubes", "spheres", "cylinders", "lines", "triangles", "texts", "models")
    TIMESTAMP_FIELD_NUMBER: _ClassVar[int]
    FRAME_ID_FIELD_NUMBER: _ClassVar[int]
    ID_FIELD_NUMBER: _ClassVar[int]
    LIFETIME_FIELD_NUMBER: _ClassVar[int]
    FRAME_LOCKED_FIELD_NUMBER: _ClassVar[int]
    METADATA_FIELD_NUMBER: _ClassVar[int]
    ARROWS_FIELD_NUMBER: _ClassVar[int]
    CUBES_FIELD_NUMBER: _ClassVar[int]
    SPHERES_FIELD_NUMBER: _ClassVar[int]
    CYLINDERS_FIELD_NUMBER: _ClassVar[int]
    LINES_FIELD_NUMBER: _ClassVar[int]
    TRIANGLES_FIELD_NUMBER: _ClassVar[int]
    TEXTS_FIELD_NUMBER: _ClassVar[int]
    MODELS_FIELD_NUMBER: _ClassVar[int]
    timestamp: _timestamp_pb2.Timestamp
    frame_id: str
    id: str
    lifetime: _duration_pb2.Duration
    frame_locked: bool
    metadata: _containers.RepeatedCompositeFieldContainer[KeyValuePair]
    arrows: _containers.RepeatedCompositeFieldContainer[ArrowPrimitive]
    cubes: _containers.RepeatedCompositeFieldContainer[CubePrimitive]
    spheres: _containers.RepeatedCompositeFieldContainer[SpherePrimitive]
    cylinders: _containers.RepeatedCompositeFieldContainer[CylinderPrimitive]
    lines: _containers.RepeatedCompositeFieldContainer[LinePrimitive]
    triangles: _containers.RepeatedCompositeFieldContainer[TriangleListPrimitive]
    texts: _containers.RepeatedCompositeFieldContainer[TextPrimitive]
    models: _containers.RepeatedCompositeFieldContainer[ModelPrimitive]
    def __init__(self, timestamp: _Optional[_Union[datetime.datetime, _timestamp_pb2.Timestamp, _Mapping]] = ..., frame_id: _Optional[str] = ..., id: _Optional[str] = ..., lifetime: _Optional[_Union[datetime.timedelta, _duration_pb2.Duration, _Mapping]] = ..., frame_locked: _Optional[bool] = ..., metadata: _Optional[_Iterable[_Union[KeyValuePair, _Mapping]]] = ..., arrows: _Optional[_Iterable[_Union[ArrowPrimitive, _Mapping]]] = ..., cubes: _Optional[_Iterable[_Union[CubePrimitive, _Mapping]]] = ..., spheres: _Optional[_Iterable[_Union[SpherePrimitive, _Mapping]]] = ..., cylinders: _Optional[_Iterable[_Union[CylinderPrimitive, _Mapping]]] = ..., lines: _Optional[_Iterable[_Union[LinePrimitive, _Mapping]]] = ..., triangles: _Optional[_Iterable[_Union[TriangleListPrimitive, _Mapping]]] = ..., texts: _Optional[_Iterable[_Union[TextPrimitive, _Mapping]]] = ..., models: _Optional[_Iterable[_Union[ModelPrimitive, _Mapping]]] = ...) -> None: ...

class SceneEntityDeletion(_message.Message):
    __slots__ = ("timestamp", "type", "id")
    class Type(int, metaclass=_enum_type_wrapper.EnumTypeWrapper):
        __slots__ = ()
        MATCHING_ID: _ClassVar[SceneEntityDeletion.Type]
        ALL: _ClassVar[SceneEntityDeletion.Type]
    MATCHING_ID: SceneEntityDeletion.Type
    ALL: SceneEntityDeletion.Type
    TIMESTAMP_FIELD_NUMBER: _ClassVar[int]
    TYPE_FIELD_NUMBER: _ClassVar[int]
    ID_FIELD_NUMBER: _ClassVar[int]
    timestamp: _timestamp_pb2.Timestamp
    type: SceneEntityDeletion.Type
    id: str
    def __init__(self, timestamp: _Optional[_Union[datetime.datetime, _timestamp_pb2.Timestamp, _Mapping]] = ..., type: _Optional[_Union[SceneEntityDeletion.Type, str]] = ..., id: _Optional[str] = ...) -> None: ...

class SceneUpdate(_message.Message):
    __slots__ = ("deletions", "entities")
    DELETIONS_FIELD_NUMBER: _ClassVar[int]
    ENTITIES_FIELD_NUMBER: _ClassVar[int]
    deletions: _containers.RepeatedCompositeFieldContainer[SceneEntityDeletion]
    entities: _containers.RepeatedCompositeFieldContainer[SceneEntity]
    def __init__(self, deletions: _Optional[_Iterable[_Union[SceneEntityDeletion, _Mapping]]] = ..., entities: _Optional[_Iterable[_Union[SceneEntity, _Mapping]]] = ...) -> None: ...

class LocationFix(_message.Message):
    __slots__ = ("frame_id", "timestamp", "latitude", "longitude", "altitude", "position_covariance", "position_covariance_type")
    class PositionCovarianceType(int, metaclass=_enum_type_wrapper.EnumTypeWrapper):
        __slots__ = ()
        UNKNOWN: _ClassVar[LocationFix.PositionCovarianceType]
        APPROXIMATED: _ClassVar[LocationFix.PositionCovarianceType]
        DIAGONAL_KNOWN: _ClassVar[LocationFix.PositionCovarianceType]
        KNOWN: _ClassVar[LocationFix.PositionCovarianceType]
    UNKNOWN: LocationFix.PositionCovarianceType
    APPROXIMATED: LocationFix.PositionCovarianceType
    DIAGONAL_KNOWN: LocationFix.PositionCovarianceType
    KNOWN: LocationFix.PositionCovarianceType
    FRAME_ID_FIELD_NUMBER: _ClassVar[int]
    TIMESTAMP_FIELD_NUMBER: _ClassVar[int]
    LATITUDE_FIELD_NUMBER: _ClassVar[int]
    LONGITUDE_FIELD_NUMBER: _ClassVar[int]
    ALTITUDE_FIELD_NUMBER: _ClassVar[int]
    POSITION_COVARIANCE_FIELD_NUMBER: _ClassVar[int]
    POSITION_COVARIANCE_TYPE_FIELD_NUMBER: _ClassVar[int]
    frame_id: str
    timestamp: _timestamp_pb2.Timestamp
    latitude: float
    longitude: float
    altitude: float
    position_covariance: _containers.RepeatedScalarFieldContainer[float]
    position_covariance_type: LocationFix.PositionCovarianceType
    def __init__(self, frame_id: _Optional[str] = ..., timestamp: _Optional[_Union[datetime.datetime, _timestamp_pb2.Timestamp, _Mapping]] = ..., latitude: _Optional[float] = ..., longitude: _Optional[float] = ..., altitude: _Optional[float] = ..., position_covariance: _Optional[_Iterable[float]] = ..., position_covariance_type: _Optional[_Union[LocationFix.PositionCovarianceType, str]] = ...) -> None: ...
