"""The seed's three layers, plus the outputs, as objects that simulation, replay and the car run.

- :class:`ExecutiveLayer`: raw sensor units in, map state out. It records the raw units and the
  GNSS fixes, drops readings older than ``run.stale_input_s`` (counted) and updates the Mapper.
- :class:`DeliberativeLayer`: map state in, plan out, at ``run.plan_rate_hz``. It lets the
  planner see every map state (waypoints), starts autonomous planning once the loop is closed,
  the RES says go or the car is driving, and plans when its rate keeper says a plan is due.
- :class:`ReactiveLayer`: pose, plan and health in, actuator command out, every control tick.
  It takes the RES and ``MISSION_SELECT`` from the readings and measures how old the pose and
  the plan it follows are.
- :class:`OutputLayer`: the outputs (recording, output hash, live view, rendered frames) at
  their own rates; it never feeds back into the loop.

:class:`orchestrator.main_loop.Main` steps them in this order every tick of a
:class:`~common.clock.SimClock` (simulation and replay: the outputs depend only on the input).
``drive`` (:mod:`orchestrator.live`) runs the very same objects on the wall clock: the reactive
layer in the real-time control process, the executive and deliberative layers each in a thread
of a second process, each at its own rate and priority (control > mapping > planning >
recording > rendering). Each layer's :class:`RateKeeper` reports how late its steps ran, as
openpilot's rate keeper does.
"""

from __future__ import annotations

import logging
import threading
import time
from collections import Counter
from collections.abc import Sequence
from typing import Any, Protocol

import numpy as np

from common.messages import (
    ActuatorCommand,
    AsState,
    CanFrame,
    GpsFix,
    Health,
    MapState,
    MissionSelect,
    Plan,
    PoseEstimate,
    RawBytes,
    Reading,
    RemoteStop,
)
from controller.pose_prediction import predict_pose
from recordings.topics import HEALTH, MAP_STATE

log = logging.getLogger(__name__)

RawUnit = RawBytes | CanFrame
SCHEDULE_TOLERANCE_S = 1e-9
"""A step due at t runs at a tick stamped t minus float rounding."""


class OutputSink(Protocol):
    """Where outputs go besides the actuators (recorder, hasher)."""

    def write(self, topic: str, message: Any, log_time_s: float) -> None: ...


def lag_summary_ms(lags_s: Sequence[float]) -> dict[str, float]:
    """Median, p99 and max (ms) of lags ``lags_s`` (s); empty for none."""
    if not len(lags_s):
        return {}
    lags = np.asarray(lags_s) * 1e3
    return {"lag_p50_ms": round(float(np.percentile(lags, 50)), 3),
            "lag_p99_ms": round(float(np.percentile(lags, 99)), 3),
            "lag_max_ms": round(float(lags.max()), 3)}


class RateKeeper:
    """A layer's schedule at ``rate_hz``: whether a step is due, and how late each ran.

    The schedule does not drift: each step is due one period after the last was due, however
    late that one ran (openpilot's ``Ratekeeper``); a step more than a period late restarts it
    from now, so a stalled layer catches up with one step, not a burst. The first step is due
    at once.
    """

    def __init__(self, name: str, rate_hz: float) -> None:
        if not rate_hz > 0.0:
            raise ValueError(f"{name}: rate must be > 0 Hz, got {rate_hz}")
        self.name = name
        self.period_s = 1.0 / rate_hz
        self.next_s: float | None = None
        """When the next step is due (s); None before the first."""
        self.lags_s: list[float] = []
        """How late (s) each step after the first ran."""

    def due(self, now_s: float) -> bool:
        """Whether a step is due at ``now_s`` (s); if so it is counted as run now."""
        if self.next_s is None:
            self.next_s = now_s + self.period_s
            return True
        if now_s + SCHEDULE_TOLERANCE_S < self.next_s:
            return False
        self.lags_s.append(max(0.0, now_s - self.next_s))
        self.next_s += self.period_s
        if self.next_s <= now_s:
            self.next_s = now_s + self.period_s
        return True

    def summary_ms(self) -> dict[str, float]:
        """Steps run, and their lag's median, p99 and max (ms); ``late`` counts steps that ran
        more than a period late."""
        out: dict[str, float] = {"period_ms": round(self.period_s * 1e3, 3),
                                 "steps": len(self.lags_s) + (self.next_s is not None)}
        if self.lags_s:
            out.update(lag_summary_ms(self.lags_s))
            out["late"] = sum(lag > self.period_s for lag in self.lags_s)
        return out


class ExecutiveLayer:
    """Sensors to map: records what arrives, drops stale readings, updates the Mapper.

    ``mapper`` None: a record-only run (the readings are recorded, no map is made).
    """

    def __init__(self, mapper: Any, stale_input_s: float, recorder: Any = None,
                 live: Any = None) -> None:
        self.mapper = mapper
        self.stale_input_s = float(stale_input_s)
        self.recorder = recorder
        self.live = live
        self.rejected: Counter[str] = Counter()
        """Readings dropped, by kind (``stale_<type>``)."""
        self.map_state: MapState | None = None
        self.lags_s: list[float] = []
        """At each map update, how old (s) the newest reading it took was: the executive's
        lag behind its sensors (0 on a simulated clock, where a tick takes what came before
        it)."""

    def admit(self, now_s: float, raw: Sequence[RawUnit], readings: Sequence[Reading]
              ) -> list[Reading]:
        """Record the raw units and the GNSS fixes; the readings not older than
        ``stale_input_s`` at ``now_s`` (s), the rest counted in :attr:`rejected`."""
        if self.recorder is not None and raw:
            self.recorder.write_raw_many(raw)
        limit = now_s - self.stale_input_s
        fresh: list[Reading] = []
        for reading in readings:
            if reading.timestamp_s < limit:
                self.rejected[f"stale_{type(reading).__name__}"] += 1
                continue
            fresh.append(reading)
            if isinstance(reading, GpsFix):
                if self.recorder is not None:
                    self.recorder.write_gps_fix(reading)
                if self.live is not None:
                    self.live.write_gps_fix(reading)
        return fresh

    def step(self, now_s: float, readings: Sequence[Reading]) -> MapState:
        """The map state at ``now_s`` (s) after the admitted ``readings``."""
        if readings:
            self.lags_s.append(max(0.0, now_s - max(r.timestamp_s for r in readings)))
        self.map_state = self.mapper.update(readings, now_s)
        return self.map_state

    def summary_ms(self) -> dict[str, float]:
        """Map updates with readings, and their lag's median, p99 and max (ms)."""
        return {"steps": len(self.lags_s), **lag_summary_ms(self.lags_s)}


class DeliberativeLayer:
    """Map to plan, at ``plan_rate_hz``."""

    def __init__(self, planner: Any, plan_rate_hz: float) -> None:
        self.planner = planner
        self.rate = RateKeeper("planner", plan_rate_hz)
        self.autonomous_started = False
        self.start_s: float | None = None
        """Wall time (s) the planner took to start autonomous planning (None: not yet)."""
        self.plan: Plan | None = None

    def observe(self, map_state: MapState) -> None:
        """Every map state, planned on or not (the planner records the waypoints driven)."""
        self.planner.observe(map_state)

    def observe_pose(self, pose: PoseEstimate) -> None:
        """The pose of every map state (:meth:`observe` where the map state stays elsewhere)."""
        self.planner.observe_pose(pose)

    def ready(self, map_state: MapState, go: bool, driving: bool) -> bool:
        """Autonomous planning starts once the loop is closed (the map is fixed), at the RES
        "go" or once the car drives (the planner then uses what it has)."""
        return bool(map_state.loop_closed or go or driving)

    def step(self, now_s: float, map_state: MapState, go: bool, driving: bool) -> Plan | None:
        """A new plan at ``now_s`` (s) when one is due, else None."""
        if not self.autonomous_started:
            if not self.ready(map_state, go, driving):
                return None
            t0 = time.perf_counter()
            self.planner.start_autonomous(map_state)
            self.start_s = time.perf_counter() - t0
            self.autonomous_started = True
        if not self.rate.due(now_s):
            return None
        self.plan = self.planner.plan(map_state, now_s)
        return self.plan


class ReactiveLayer:
    """Pose and plan to actuator command, every control tick: the Controller and its safety
    supervisor (and the AS state machine it steps), given the pose carried forward to the tick
    (:func:`controller.pose_prediction.predict_pose`). ``configured_mission``: the mission the
    run was configured for (a different ``MISSION_SELECT`` is logged once)."""

    def __init__(self, controller: Any, control_rate_hz: float,
                 configured_mission: str) -> None:
        self.controller = controller
        self.rate = RateKeeper("controller", control_rate_hz)
        self.configured_mission = configured_mission
        self.remote: RemoteStop | None = None
        self.mission_select: MissionSelect | None = None
        """The last ``MISSION_SELECT`` the car sent (None: none yet)."""
        self.command: ActuatorCommand | None = None
        self.plan_ages_s: list[float] = []
        """Age (s) of the plan followed at each tick while driving."""
        self.pose_ages_s: list[float] = []
        """Age (s) of the pose at each tick while driving."""

    @property
    def go(self) -> bool:
        return self.remote is not None and self.remote.go

    @property
    def driving(self) -> bool:
        return bool(self.controller.state == AsState.DRIVING)

    def take(self, readings: Sequence[Reading]) -> None:
        """The RES and ``MISSION_SELECT`` among ``readings`` (the rest are not its own)."""
        for reading in readings:
            if isinstance(reading, RemoteStop):
                self.remote = reading
            elif isinstance(reading, MissionSelect):
                self._select_mission(reading)

    def _select_mission(self, reading: MissionSelect) -> None:
        """Hand the car's mission to the AS state machine; say once when it is not the
        mission this run was configured for (the configuration sets the laps and the
        exploration)."""
        previous = self.mission_select
        self.mission_select = reading
        self.controller.select_mission(reading.mission)
        if previous is not None and previous.mission == reading.mission:
            return
        if (reading.mission.selectable
                and reading.mission.name.lower() != self.configured_mission):
            log.warning("MISSION_SELECT %s is not the configured mission %s: the stack drives "
                        "the configuration's laps and exploration", reading.mission.name.lower(),
                        self.configured_mission)

    def step(self, now_s: float, pose: PoseEstimate | None, plan: Plan | None,
             health: Health) -> ActuatorCommand:
        """The command at ``now_s`` (s); full brake in READY while there is no pose yet."""
        self.rate.due(now_s)
        if pose is None:
            self.command = ActuatorCommand(now_s, 0.0, 1.0, 0.0, AsState.READY)
            return self.command
        moved = predict_pose(pose, now_s, self.controller.config.pose_prediction_max_s)
        self.command = self.controller.command(now_s, moved, plan, health, self.remote)
        if self.controller.state == AsState.DRIVING:
            self.pose_ages_s.append(now_s - pose.timestamp_s)
            if plan is not None:
                self.plan_ages_s.append(now_s - plan.timestamp_s)
        return self.command

    def as_status(self, now_s: float) -> Any:
        """The AS state, mission, lap and ASSI mode for ``AS_STATUS``."""
        return self.controller.as_status(now_s)


class OutputLayer:
    """The outputs: every plan and command and the map state at ``output_rate_hz`` to the
    ``sinks`` (recorder, output hash) and the live view, the health to the recording, frames
    to the visualiser at ``frame_rate_hz``. Thread-safe: ``drive``'s layers emit from their
    own threads."""

    def __init__(self, sinks: Sequence[OutputSink], output_rate_hz: float,
                 frame_rate_hz: float, recorder: Any = None, visualiser: Any = None,
                 live: Any = None) -> None:
        self.sinks = list(sinks)
        self.recorder = recorder
        self.visualiser = visualiser
        self.live = live
        self.output_rate = RateKeeper("outputs", output_rate_hz)
        self.frame_rate = RateKeeper("frames", max(frame_rate_hz, 1e-6))
        self._lock = threading.Lock()

    def emit(self, topic: str, message: Any, now_s: float) -> None:
        """``message`` on ``topic`` at ``now_s`` (s) to every sink and the live view."""
        with self._lock:
            for sink in self.sinks:
                sink.write(topic, message, now_s)
        if self.live is not None:
            self.live.write(topic, message, now_s)

    def write_health(self, health: Health, now_s: float) -> None:
        """The health the controller saw, to the recording and the live view."""
        if self.recorder is not None:
            with self._lock:
                self.recorder.write(HEALTH, health, now_s)
        if self.live is not None:
            self.live.write(HEALTH, health, now_s)

    def step(self, now_s: float, map_state: MapState, plan: Plan | None,
             command: ActuatorCommand | None, health: Health | None = None,
             truth: Any = None, track: Any = None) -> None:
        """The map state (and ``health``) when their output is due, a frame when one is."""
        if self.output_rate.due(now_s):
            self.emit(MAP_STATE, map_state, now_s)
            if self.visualiser is not None:
                pose = map_state.pose
                self.visualiser.note_pose(
                    pose.x_m, pose.y_m, pose.speed_mps, now_s,
                    plan.lap if plan is not None else 0,
                    command is not None and command.state == AsState.DRIVING)
            if health is not None:
                self.write_health(health, now_s)
        if self.visualiser is not None and self.frame_rate.due(now_s):
            self.visualiser.submit(map_state, plan, command, truth=truth, track=track,
                                   health=health)
