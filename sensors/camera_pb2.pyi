from google.protobuf.internal import containers as _containers
from google.protobuf.internal import enum_type_wrapper as _enum_type_wrapper
from google.protobuf import descriptor as _descriptor
from google.protobuf import message as _message
from collections.abc import Iterable as _Iterable, Mapping as _Mapping
from typing import ClassVar as _ClassVar, Optional as _Optional, Union as _Union

DESCRIPTOR: _descriptor.FileDescriptor

class Colour(int, metaclass=_enum_type_wrapper.EnumTypeWrapper):
    __slots__ = ()
    UNKNOWN: _ClassVar[Colour]
    BLUE: _ClassVar[Colour]
    YELLOW: _ClassVar[Colour]
    ORANGE: _ClassVar[Colour]
    BIG_ORANGE: _ClassVar[Colour]
UNKNOWN: Colour
BLUE: Colour
YELLOW: Colour
ORANGE: Colour
BIG_ORANGE: Colour

class CameraCones(_message.Message):
    __slots__ = ("timestamp_s", "frame_id", "cones")
    TIMESTAMP_S_FIELD_NUMBER: _ClassVar[int]
    FRAME_ID_FIELD_NUMBER: _ClassVar[int]
    CONES_FIELD_NUMBER: _ClassVar[int]
    timestamp_s: float
    frame_id: int
    cones: _containers.RepeatedCompositeFieldContainer[Cone]
    def __init__(self, timestamp_s: _Optional[float] = ..., frame_id: _Optional[int] = ..., cones: _Optional[_Iterable[_Union[Cone, _Mapping]]] = ...) -> None: ...

class Cone(_message.Message):
    __slots__ = ("x_m", "y_m", "colour", "confidence")
    X_M_FIELD_NUMBER: _ClassVar[int]
    Y_M_FIELD_NUMBER: _ClassVar[int]
    COLOUR_FIELD_NUMBER: _ClassVar[int]
    CONFIDENCE_FIELD_NUMBER: _ClassVar[int]
    x_m: float
    y_m: float
    colour: Colour
    confidence: float
    def __init__(self, x_m: _Optional[float] = ..., y_m: _Optional[float] = ..., colour: _Optional[_Union[Colour, str]] = ..., confidence: _Optional[float] = ...) -> None: ...
