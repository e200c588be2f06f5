"""The typed messages between the layers of ``drive``'s two processes (:mod:`orchestrator.live`,
the reactive layer, and :mod:`orchestrator.live_worker`, the executive and deliberative layers).

They cross :class:`orchestrator.live_link.Link` pickled. Each is a frozen dataclass, so a
message that does not match what its reader expects fails at the reader's ``isinstance``
(counted and logged as unknown), never as a tuple unpacked the wrong way.

To the reactive layer: :class:`Loaded`, :class:`PoseUpdate`, :class:`PlanUpdate`,
:class:`HealthUpdate`, :class:`LayerError`, :class:`Final`. From it: :class:`Start`,
:class:`ControlTick`, :class:`Stop`. Between the executive process and the planner's
(:mod:`orchestrator.live_planner`): :class:`Loaded`, :class:`MapRequest`, :class:`PlanUpdate`,
:class:`LayerError`, :class:`Final` from the planner; :class:`Start`, :class:`PlannerInput`,
:class:`Stop` to it.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from common.clock import RealClock
from common.messages import (
    ActuatorCommand,
    CanFrame,
    Health,
    MapState,
    Plan,
    PoseEstimate,
    RawBytes,
    Reading,
)


@dataclass(frozen=True, slots=True)
class Loaded:
    """The executive process has built its layers; it starts its sensors at :class:`Start`."""


@dataclass(frozen=True, slots=True)
class Start:
    """The run's clock (it starts with the sensors): start the receivers and the layers."""

    clock: RealClock


@dataclass(frozen=True, slots=True)
class Stop:
    """End the run: join the layers, close the recording, send :class:`Final`."""


@dataclass(frozen=True, slots=True)
class ControlTick:
    """What one control tick hands the executive process at ``now_s`` (s): the CAN frames
    received and their readings (for the mapper and the recording), the command sent and the
    health the controller saw (each None when there is none to record)."""

    now_s: float
    can_raw: tuple[CanFrame | RawBytes, ...] = ()
    """The CAN bus's raw units (frames; a replayed or emulated bus may hand raw bytes)."""
    can_readings: tuple[Reading, ...] = ()
    command: ActuatorCommand | None = None
    health: Health | None = None


@dataclass(frozen=True, slots=True)
class PoseUpdate:
    """The executive layer's latest pose, whether its loop is closed and how many cones it
    has mapped."""

    pose: PoseEstimate
    loop_closed: bool
    landmarks: int


@dataclass(frozen=True, slots=True)
class PlanUpdate:
    """The deliberative layer's latest plan."""

    plan: Plan


@dataclass(frozen=True, slots=True)
class HealthUpdate:
    """The executive process's sensors' health (measured at ``health.timestamp_s``)."""

    health: Health


@dataclass(frozen=True, slots=True)
class LayerError:
    """A layer of the executive process failed: the run stops with ``text``."""

    text: str


@dataclass(frozen=True, slots=True)
class Final:
    """The executive process's statistics at its end (stage times, lags, output hash...)."""

    stats: dict[str, Any] = field(default_factory=dict)


@dataclass(frozen=True, slots=True)
class MapRequest:
    """The planner is due to plan: it asks for the newest map (:class:`PlannerInput`)."""


@dataclass(frozen=True, slots=True)
class PlannerInput:
    """What the planner plans on: the executive's newest ``map_state`` (None before the first),
    the ``poses`` of the map updates since the last request (the exploration records its
    waypoints from them), the RES ``go`` and whether the car is ``driving``."""

    map_state: MapState | None
    poses: tuple[PoseEstimate, ...] = ()
    go: bool = False
    driving: bool = False
