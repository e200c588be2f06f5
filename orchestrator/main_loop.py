"""Main: owns the managers and moves all data between them, one control tick at a time.

``Main.tick`` steps the layers of :mod:`orchestrator.layers` for simulation and replay: a
:class:`~common.clock.SimClock` is stepped tick by tick and the raw sensor units produced up to
the tick are handed in (``raw_in``); the layers then run in a fixed order, so the outputs depend
only on the raw input and are identical at any replay rate. On the car (:mod:`orchestrator.live`)
the very same layer objects run on the wall clock instead: the reactive layer (control, safety,
CAN) in its own process at real-time priority, the executive and deliberative layers in a second
process, so that they never delay a control tick.

Data flow per tick (ARCHITECTURE.md, "One loop")::

    batch     = sensors.take()                           # parsed, time ordered
    readings  = executive.admit(now, batch)              # raw units recorded, stale dropped
    reactive.take(readings)                              # the RES, MISSION_SELECT
    map_state = executive.step(now, readings)            # executive layer: the Mapper
    plan      = deliberative.step(now, map_state, ...)   # deliberative layer, plan_rate_hz
    command   = reactive.step(now, pose, plan, health)   # reactive layer, every tick
    status    = sensors.report_status(...)               # AS_STATUS on CAN: 10 Hz, on a change
    output.step(now, map_state, plan, command)           # recording, live view, frames

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
from typing import Any

import numpy as np

from common.messages import (
    ActuatorCommand,
    CanFrame,
    GroundTruth,
    Health,
    MapState,
    MissionSelect,
    Plan,
    RemoteStop,
)
from orchestrator.config import AppConfig
from orchestrator.layers import (
    DeliberativeLayer,
    ExecutiveLayer,
    OutputLayer,
    OutputSink,
    RawUnit,
    ReactiveLayer,
)
from recordings.topics import COMMAND, PLAN

log = logging.getLogger(__name__)

__all__ = ["Main", "OutputSink", "RawUnit", "StageTimes"]


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
    ``controller`` follow the interfaces of their packages and are run by the layers of
    :mod:`orchestrator.layers`; ``outputs`` receive every map state (at
    ``run.output_record_rate_hz``), plan and command in order (the recorder and the output
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
        self.recorder = recorder
        self.live = live
        run = config.run
        self.executive = ExecutiveLayer(mapper, run.stale_input_s, recorder, live)
        self.deliberative = DeliberativeLayer(planner, run.plan_rate_hz)
        self.reactive = ReactiveLayer(controller, run.control_rate_hz, config.mission.mission)
        self.output = OutputLayer(outputs, run.output_record_rate_hz, config.visualiser.fps,
                                  recorder, visualiser, live)
        self.times = StageTimes()
        self.health: Health | None = None
        self.status_frame: CanFrame | None = None
        """The ``AS_STATUS`` frame sent this tick (None: none was due)."""
        self.truth: GroundTruth | None = None
        self.track: Any = None
        self.ticks = 0

    # the managers and what the layers hold, under the names the runs read
    @property
    def controller(self) -> Any:
        return self.reactive.controller

    @property
    def planner(self) -> Any:
        return self.deliberative.planner

    @property
    def mapper(self) -> Any:
        return self.executive.mapper

    @property
    def map_state(self) -> MapState | None:
        return self.executive.map_state

    @property
    def plan(self) -> Plan | None:
        """The last plan (None before the first)."""
        return self.deliberative.plan

    @property
    def command(self) -> ActuatorCommand | None:
        """The last command (None before the first tick)."""
        return self.reactive.command

    @property
    def rejected(self) -> Counter[str]:
        return self.executive.rejected

    @property
    def remote(self) -> RemoteStop | None:
        return self.reactive.remote

    @property
    def mission_select(self) -> MissionSelect | None:
        return self.reactive.mission_select

    @property
    def autonomous_started(self) -> bool:
        return self.deliberative.autonomous_started

    def lags_ms(self) -> dict[str, dict[str, float]]:
        """Each layer's rate keeper: steps and lag (ms; 0 on a simulated clock)."""
        lags = {keeper.name: keeper.summary_ms()
                for keeper in (self.reactive.rate, self.deliberative.rate,
                               self.output.output_rate)}
        lags["mapper"] = self.executive.summary_ms()
        return lags

    # ------------------------------------------------------------------ one tick
    def tick(self, now_s: float, raw_in: Sequence[RawUnit] = ()) -> ActuatorCommand:
        """Run one control tick at ``now_s``; returns the command for the actuators."""
        t0 = time.perf_counter()
        if raw_in:
            self.sensors.ingest(raw_in)
        batch = self.sensors.take()
        t1 = time.perf_counter()
        self.times.add("sensors", t1 - t0)

        readings = self.executive.admit(now_s, batch.raw, batch.readings)
        outputs_s = time.perf_counter() - t1  # the raw units handed to the recorder
        self.reactive.take(readings)
        t2 = time.perf_counter()
        map_state = self.executive.step(now_s, readings)
        t3 = time.perf_counter()
        self.times.add("mapper", t3 - t2)

        self.deliberative.observe(map_state)
        t4 = time.perf_counter()
        plan = self.deliberative.step(now_s, map_state, self.reactive.go, self.reactive.driving)
        if plan is not None:
            t4p = time.perf_counter()
            self.times.add("planner", t4p - t4)
            self.output.emit(PLAN, plan, now_s)
            outputs_s += time.perf_counter() - t4p

        t5 = time.perf_counter()
        self.health = self.sensors.health(now_s)
        t5h = time.perf_counter()
        self.times.add("health", t5h - t5)
        command = self.reactive.step(now_s, map_state.pose, self.plan, self.health)
        self.status_frame = self.sensors.report_status(self.reactive.as_status(now_s))
        t6 = time.perf_counter()
        self.times.add("controller", t6 - t5h)

        self.output.emit(COMMAND, command, now_s)
        self.output.step(now_s, map_state, self.plan, command, self.health,
                         truth=self.truth, track=self.track)
        t7 = time.perf_counter()
        self.times.add("outputs", outputs_s + t7 - t6)
        self.times.add("tick", t7 - t0)
        self.ticks += 1
        return command
