"""What one frame shows, as plain arrays: cheap to build in the loop and to send to a process.

The Visualiser depends only on the message types (common.messages): replacing the Mapper needs
no change here. A :class:`FrameData` is made from a map state, a plan and a command (and, in
simulation, the truth) by :func:`frame_from_messages`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from common.messages import (
    ActuatorCommand,
    AsState,
    GroundTruth,
    Health,
    MapState,
    Plan,
)
from common.track import TrackLayout


@dataclass(slots=True)
class TrackData:
    """The true track (simulation only): cones (N, 2) with colour and size classes."""

    cones_xy_m: np.ndarray
    colours: np.ndarray
    sizes: np.ndarray
    name: str = ""


@dataclass(slots=True)
class FrameData:
    """Everything drawn in one frame. Arrays are world-frame metres unless named otherwise.

    ``cones_xy_m`` (N, 2), ``cones_cov`` (N, 2, 2), ``cones_colour`` (N,), ``cones_conf01`` (N,)
    opacity 0..1; ``pose`` (x_m, y_m, yaw_rad); ``pose_cov`` (2, 2); ``baseframe_xy_m`` (M, 2);
    ``candidates`` list of (K, 2); ``waypoints_xy_m`` (W, 2); ``truth_pose`` or None.
    """

    t_s: float
    pose: tuple[float, float, float]
    pose_cov: np.ndarray
    speed_mps: float
    cones_xy_m: np.ndarray
    cones_cov: np.ndarray
    cones_colour: np.ndarray
    cones_conf01: np.ndarray
    baseframe_xy_m: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    candidates: list[np.ndarray] = field(default_factory=list)
    chosen_index: int = -1
    waypoints_xy_m: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    throttle: float = 0.0
    brake: float = 0.0
    steering_rad: float = 0.0
    state: str = "OFF"
    loop_closed: bool = False
    target_speed_mps: float = math.nan
    truth_pose: tuple[float, float, float] | None = None
    stale_sources: tuple[str, ...] = ()
    trace_xy_m: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    """Poses (K, 2) since the previous frame, for the driven trace (the frame's own pose is added
    after them)."""
    trace_speed_mps: np.ndarray = field(default_factory=lambda: np.zeros(0))
    """The speed (K,) at each of ``trace_xy_m`` (m/s; the trace is coloured by it)."""
    lap: int = 0
    """Laps completed (the plan's counter)."""
    laps_target: int = 0
    """Laps the mission drives (0: not known)."""
    lap_times_s: tuple[float, ...] = ()
    """Times (s) of the laps completed so far."""


def frame_from_messages(
    map_state: MapState,
    plan: Plan | None = None,
    command: ActuatorCommand | None = None,
    truth: GroundTruth | None = None,
    health: Health | None = None,
) -> FrameData:
    """Build the frame's data from the messages Main hands over (no copies of big arrays)."""
    pose = map_state.pose
    cones = map_state.cones
    conf = np.asarray(cones.confidence, dtype=float)
    top = float(conf.max()) if conf.size else 1.0
    conf01 = np.clip(conf / top, 0.15, 1.0) if top > 0 else np.ones_like(conf)
    frame = FrameData(
        t_s=map_state.timestamp_s,
        pose=(pose.x_m, pose.y_m, pose.yaw_rad),
        pose_cov=np.asarray(pose.covariance[:2, :2]),
        speed_mps=pose.speed_mps,
        cones_xy_m=cones.xy_m,
        cones_cov=cones.covariance,
        cones_colour=cones.colour,
        cones_conf01=conf01,
        loop_closed=map_state.loop_closed,
    )
    if plan is not None:
        if plan.baseframe is not None:
            frame.baseframe_xy_m = np.stack([plan.baseframe.x_m, plan.baseframe.y_m], axis=1)
        frame.candidates = list(plan.candidates)
        frame.chosen_index = plan.chosen_index
        frame.waypoints_xy_m = plan.waypoints_xy_m
        frame.target_speed_mps = plan.target_speed_mps
        frame.lap = plan.lap
    if command is not None:
        frame.throttle = command.throttle
        frame.brake = command.brake
        frame.steering_rad = command.steering_rad
        frame.state = AsState(command.state).name
    if truth is not None:
        frame.truth_pose = (truth.x_m, truth.y_m, truth.yaw_rad)
    if health is not None:
        frame.stale_sources = health.stale_sources()
        frame.state = AsState(health.state).name if command is None else frame.state
    return frame


def track_data(track: TrackLayout | None) -> TrackData | None:
    """What the renderer draws of the true track (simulation only; None without one)."""
    if track is None:
        return None
    return TrackData(
        cones_xy_m=np.asarray(track.cones_xy_m, dtype=float).reshape(-1, 2),
        colours=np.asarray(track.colours, dtype=np.int64),
        sizes=np.asarray(track.sizes, dtype=np.int64),
        name=track.name,
    )
