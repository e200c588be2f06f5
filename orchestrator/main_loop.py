"""Main: owns the managers and moves all data between them, one control tick at a time.

``Main.tick`` runs the layers for simulation and replay: a :class:`~common.clock.SimClock` is
stepped tick by tick and the raw sensor units produced up to the tick are handed in
(``raw_in``); the layers then run in a fixed order, so the outputs depend only on the raw input
and are identical at any replay rate. On the car (:mod:`orchestrator.live`) the same managers
are driven by the wall clock instead: the reactive layer (control, safety, CAN) runs in its own
process at real-time priority, and the sensor receivers, mapping and planning run in a second
process, so that they never delay a control tick.

Data flow per tick (ARCHITECTURE.md, "One loop")::

    readings  = sensors.take()                 # parsed, time ordered
    recorder.write_raw(raw)                    # raw units, as received
    controller.select_mission(mission)         # the last MISSION_SELECT, to the AS machine
    map_state = mapper.update(readings)        # executive layer
    plan      = planner.plan(map_state)        # deliberative layer, plan_rate_hz
    command   = controller.command(...)        # reactive layer, every tick
    status    = sensors.report_status(...)     # AS_STATUS on CAN: 10 Hz and on a change
    visualiser.submit(map_state, plan, command)

The AS state is that of ONE :class:`controller.as_state_machine.AsStateMachine`, which the
Controller's safety supervisor steps each tick (``controller.as_machine``): Main hands it the
mission the car selects in ``MISSION_SELECT`` and reports its ``AS_STATUS`` (AS state, mission,
lap, ASSI mode) back on CAN at the DBC's cycle time (10 Hz) and at once on every change
(``status_frame``: the frame sent this tick, None when none was due).
"""

from __future__ import annotations

import logging
import time
from collections import Counter, defaultdict
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

from common.messages import (
    ActuatorCommand,
    AsState,
    CanFrame,
    GpsFix,
    GroundTruth,
    Health,
    MapState,
    MissionSelect,
    Plan,
    RawBytes,
    Reading,
    RemoteStop,
)
from orchestrator.config import AppConfig
from recordings.topics import COMMAND, HEALTH, MAP_STATE, PLAN

log = logging.getLogger(__name__)

RawUnit = RawBytes | CanFrame


class OutputSink(Protocol):
    """Where Main's outputs go besides the actuators (recorder, hasher)."""

    def write(self, topic: str, message: Any, log_time_s: float) -> None: ...


@dataclass
class StageTimes:
    """Wall time (s) spent in each stage of each tick, for the run's timing report."""

    samples: dict[str, list[float]] = field(default_factory=lambda: defaultdict(list))

    def add(self, stage: str, seconds: float) -> None:
        self.samples[stage].append(seconds)

    def summary_ms(self) -> dict[str, dict[str, float]]:
        """Per stage: mean, p99 and max in milliseconds, how many times it ran (``count``) and
        its total time (``total_s``)."""
        out: dict[str, dict[str, float]] = {}
        for stage, values in self.samples.items():
            arr = np.asarray(values) * 1e3
            out[stage] = {
                "mean_ms": round(float(arr.mean()), 4),
                "p99_ms": round(float(np.percentile(arr, 99)), 4),
                "max_ms": round(float(arr.max()), 4),
                "count": int(arr.size),
                "total_s": round(float(arr.sum()) / 1e3, 4),
            }
        return out


class Main:
    """Tier 1: owns every manager and runs one tick of the loop at a time.

    ``sensors`` is a :class:`sensors.manager.SensorManager`; ``mapper``, ``planner`` and
    ``controller`` follow the interfaces of their packages; ``outputs`` receive every map state
    (at ``run.output_record_rate_hz``), plan and command in order (the recorder and the output
    hasher); ``visualiser`` (optional) receives frames it may drop; ``live`` (optional, a
    :class:`recordings.live_server.LiveServer`) receives the same messages as ``outputs`` plus
    the health and GNSS fixes, and never blocks.
    """

    def __init__(
        self,
        config: AppConfig,
        *,
        sensors: Any,
        mapper: Any,
        planner: Any,
        controller: Any,
        outputs: Sequence[OutputSink] = (),
        recorder: Any = None,
        visualiser: Any = None,
        live: Any = None,
    ) -> None:
        self.config = config
        self.sensors = sensors
        self.mapper = mapper
        self.planner = planner
        self.controller = controller
        self.outputs = list(outputs)
        self.recorder = recorder
        self.visualiser = visualiser
        self.live = live
        self.times = StageTimes()
        self.rejected: Counter[str] = Counter()
        self.map_state: MapState | None = None
        self.plan: Plan | None = None
        self.command: ActuatorCommand | None = None
        self.health: Health | None = None
        self.remote: RemoteStop | None = None
        self.mission_select: MissionSelect | None = None
        """The last ``MISSION_SELECT`` the car sent (None: none yet)."""
        self.status_frame: CanFrame | None = None
        """The ``AS_STATUS`` frame sent this tick (None: none was due)."""
        self.truth: GroundTruth | None = None
        self.track: Any = None
        self.autonomous_started = False
        self._plan_period_s = 1.0 / config.run.plan_rate_hz
        self._output_period_s = 1.0 / config.run.output_record_rate_hz
        self._frame_period_s = 1.0 / max(config.visualiser.fps, 1e-6)
        self._next_plan_s = 0.0
        self._next_output_s = 0.0
        self._next_frame_s = 0.0
        self.ticks = 0

    # ------------------------------------------------------------------ one tick
    def tick(self, now_s: float, raw_in: Sequence[RawUnit] = ()) -> ActuatorCommand:
        """Run one control tick at ``now_s``; returns the command for the actuators."""
        t0 = time.perf_counter()
        if raw_in:
            self.sensors.ingest(raw_in)
        batch = self.sensors.take()
        t1 = time.perf_counter()
        self.times.add("sensors", t1 - t0)

        if self.recorder is not None:
            for raw in batch.raw:
                self.recorder.write_raw(raw)
        readings = self._fresh(batch.readings, now_s)
        for reading in readings:
            if isinstance(reading, RemoteStop):
                self.remote = reading
            elif isinstance(reading, MissionSelect):
                self._select_mission(reading)
            elif isinstance(reading, GpsFix):
                if self.recorder is not None:
                    self.recorder.write_gps_fix(reading)
                if self.live is not None:
                    self.live.write_gps_fix(reading)

        t2 = time.perf_counter()
        self.map_state = self.mapper.update(readings, now_s)
        t3 = time.perf_counter()
        self.times.add("mapper", t3 - t2)

        self.planner.observe(self.map_state)
        if not self.autonomous_started and self._ready_to_plan():
            self.planner.start_autonomous(self.map_state)
            self.autonomous_started = True
        if self.autonomous_started and now_s + 1e-9 >= self._next_plan_s:
            self._next_plan_s = now_s + self._plan_period_s
            t4 = time.perf_counter()
            self.plan = self.planner.plan(self.map_state, now_s)
            self.times.add("planner", time.perf_counter() - t4)
            self._emit(PLAN, self.plan, now_s)

        t5 = time.perf_counter()
        self.health = self.sensors.health(now_s)
        t5h = time.perf_counter()
        self.times.add("health", t5h - t5)
        self.command = self.controller.command(
            now_s, self.map_state.pose, self.plan, self.health, self.remote
        )
        self.status_frame = self.sensors.report_status(self.controller.as_status(now_s))
        t6 = time.perf_counter()
        self.times.add("controller", t6 - t5h)

        self._emit(COMMAND, self.command, now_s)
        if now_s + 1e-9 >= self._next_output_s:
            self._next_output_s = now_s + self._output_period_s
            self._emit(MAP_STATE, self.map_state, now_s)
            if self.visualiser is not None:
                pose = self.map_state.pose
                self.visualiser.note_pose(
                    pose.x_m, pose.y_m, pose.speed_mps, now_s,
                    self.plan.lap if self.plan is not None else 0,
                    self.command.state == AsState.DRIVING)
            if self.recorder is not None:
                self.recorder.write(HEALTH, self.health, now_s)
            if self.live is not None:
                self.live.write(HEALTH, self.health, now_s)
        if self.visualiser is not None and now_s + 1e-9 >= self._next_frame_s:
            self._next_frame_s = now_s + self._frame_period_s
            self.visualiser.submit(
                self.map_state, self.plan, self.command, truth=self.truth, track=self.track,
                health=self.health,
            )
        self.times.add("tick", time.perf_counter() - t0)
        self.ticks += 1
        return self.command

    def _select_mission(self, reading: MissionSelect) -> None:
        """Hand the car's mission to the AS state machine; say once when it is not the
        mission this run was configured for (the configuration sets the laps and the
        exploration)."""
        previous = self.mission_select
        self.mission_select = reading
        self.controller.select_mission(reading.mission)
        if previous is not None and previous.mission == reading.mission:
            return
        configured = self.config.mission.mission
        if reading.mission.selectable and reading.mission.name.lower() != configured:
            log.warning("MISSION_SELECT %s is not the configured mission %s: the stack drives "
                        "the configuration's laps and exploration", reading.mission.name.lower(),
                        configured)

    def _ready_to_plan(self) -> bool:
        """The baseframe is built once the loop is closed (the map is fixed), or at the RES
        "go" when there was no loop closure (the planner then uses what it has)."""
        assert self.map_state is not None
        go = self.remote is not None and self.remote.go
        return bool(self.map_state.loop_closed or go or self.controller.state == AsState.DRIVING)

    def _fresh(self, readings: Sequence[Reading], now_s: float) -> list[Reading]:
        """Readings not older than ``run.stale_input_s``; the rest are counted and dropped."""
        limit = now_s - self.config.run.stale_input_s
        fresh = []
        for reading in readings:
            if reading.timestamp_s < limit:
                self.rejected[f"stale_{type(reading).__name__}"] += 1
                continue
            fresh.append(reading)
        return fresh

    def _emit(self, topic: str, message: Any, now_s: float) -> None:
        for sink in self.outputs:
            sink.write(topic, message, now_s)
        if self.live is not None:
            self.live.write(topic, message, now_s)
