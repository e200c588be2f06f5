"""Main on the car: live sensors, three layers in their own threads, commands out on CAN.

- Reactive layer (this module's control loop, on the calling thread): every 1 / control_rate_hz
  on the wall clock it reads the latest pose, plan, health and RES state, asks the Controller
  for a command and sends it on CAN. It never waits for the other layers: they hand over their
  latest result through a reference swap.
- Executive layer (thread ``mapper``): takes the Sensor Manager's readings, records the raw units,
  updates the Mapper, lets the planner record waypoints.
- Deliberative layer (thread ``planner``): plans at plan_rate_hz from the latest map state.

Ctrl-C and SIGTERM end the run cleanly: the car is commanded to stop (full brake frames), the
threads are joined and the recording is closed.
"""

from __future__ import annotations

import json
import logging
import math
import signal
import sys
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from common.clock import RealClock
from common.config import AppConfig
from common.messages import (
    ActuatorCommand,
    AsState,
    GpsFix,
    MapState,
    Plan,
    RemoteStop,
)
from controller.controller import Controller
from mapper.mapper import Mapper
from orchestrator.main_loop import StageTimes
from orchestrator.outputs import HashSink
from planner.path_planner import PathPlanner
from recordings.recorder import Recorder
from recordings.topics import COMMAND, HEALTH, MAP_STATE, PLAN
from sensors.manager import SensorManager

log = logging.getLogger(__name__)


@dataclass
class DriveOptions:
    """``drive`` / ``record`` options."""

    out_dir: Path
    laps: int | None = None
    record: bool = True
    control: bool = True
    seconds: float | None = None
    render: bool = False
    recording_name: str = "recording.mcap"


@dataclass
class _Shared:
    """Latest results handed between the layers (each a single reference: swaps are atomic)."""

    map_state: MapState | None = None
    plan: Plan | None = None
    remote: RemoteStop | None = None
    stop: threading.Event = field(default_factory=threading.Event)
    errors: list[str] = field(default_factory=list)


class LiveMain:
    """Main for the car: owns the managers, runs the layers in their own threads."""

    def __init__(self, config: AppConfig, options: DriveOptions) -> None:
        self.config = config
        self.options = options
        if options.laps is not None:
            config.controller.laps = options.laps
        self.clock = RealClock()
        self.sensors = SensorManager(config, self.clock)
        self.mapper = Mapper(config)
        self.planner = PathPlanner(config)
        self.controller = Controller(config)
        self.hasher = HashSink()
        self.recorder: Recorder | None = None
        options.out_dir.mkdir(parents=True, exist_ok=True)
        if options.record:
            self.recorder = Recorder(options.out_dir / options.recording_name, config.recording)
        self.visualiser: Any = None
        if options.render:
            from visualiser.visualiser import Visualiser

            self.visualiser = Visualiser(config, options.out_dir / "frames")
        self.shared = _Shared()
        self.times = StageTimes()
        self.periods_s: list[float] = []
        self.autonomous_started = False
        self._lock = threading.Lock()
        self._final_health: Any = None

    # ------------------------------------------------------------------ layers
    def _executive(self) -> None:
        shared = self.shared
        next_output_s = 0.0
        while not shared.stop.is_set():
            try:
                batch = self.sensors.take()
                if not batch.raw and not batch.readings:
                    time.sleep(0.002)
                    continue
                now_s = self.clock.now_s()
                if self.recorder is not None:
                    for raw in batch.raw:
                        self.recorder.write_raw(raw)
                for reading in batch.readings:
                    if isinstance(reading, RemoteStop):
                        shared.remote = reading
                    elif isinstance(reading, GpsFix) and self.recorder is not None:
                        self.recorder.write_gps_fix(reading)
                if not self.options.control:
                    continue
                t0 = time.perf_counter()
                map_state = self.mapper.update(batch.readings, now_s)
                self.times.add("mapper", time.perf_counter() - t0)
                shared.map_state = map_state
                self.planner.observe(map_state)
                if now_s >= next_output_s:
                    next_output_s = now_s + 1.0 / self.config.run.output_record_rate_hz
                    self._emit(MAP_STATE, map_state, now_s)
            except Exception as exc:  # a crash here must stop the car, never go silent
                log.exception("executive layer failed")
                shared.errors.append(f"mapper: {exc!r}")
                shared.stop.set()

    def _deliberative(self) -> None:
        shared = self.shared
        period_s = 1.0 / self.config.run.plan_rate_hz
        next_s = self.clock.now_s()
        while not shared.stop.is_set():
            try:
                next_s += period_s
                self.clock.sleep_until(next_s)
                map_state = shared.map_state
                if map_state is None:
                    continue
                remote = shared.remote
                go = remote is not None and remote.go
                if not self.autonomous_started and (map_state.loop_closed or go):
                    self.planner.start_autonomous(map_state)
                    self.autonomous_started = True
                if not self.autonomous_started:
                    continue
                now_s = self.clock.now_s()
                t0 = time.perf_counter()
                plan = self.planner.plan(map_state, now_s)
                self.times.add("planner", time.perf_counter() - t0)
                shared.plan = plan
                self._emit(PLAN, plan, now_s)
            except Exception as exc:
                log.exception("deliberative layer failed")
                shared.errors.append(f"planner: {exc!r}")
                shared.stop.set()

    def _emit(self, topic: str, message: Any, now_s: float) -> None:
        with self._lock:
            self.hasher.write(topic, message, now_s)
            if self.recorder is not None:
                self.recorder.write(topic, message, now_s)

    # ------------------------------------------------------------------ the reactive loop
    def run(self) -> dict[str, Any]:
        """Drive until finished, a stop, ``seconds`` or a signal; returns the summary."""
        shared = self.shared
        previous = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}

        def on_signal(signum: int, _frame: Any) -> None:
            log.warning("signal %d: stopping the car", signum)
            shared.stop.set()

        for s in previous:
            signal.signal(s, on_signal)
        sys.setswitchinterval(0.0005)
        stop_reason = "signal"
        self.sensors.start()
        threads = [threading.Thread(target=self._executive, name="mapper", daemon=True)]
        if self.options.control:
            threads.append(threading.Thread(target=self._deliberative, name="planner",
                                            daemon=True))
        for thread in threads:
            thread.start()
        period_s = 1.0 / self.config.run.control_rate_hz
        start_s = self.clock.now_s()
        next_s = start_s
        last_tick_s = math.nan
        standstill_since: float | None = None
        try:
            while not shared.stop.is_set():
                next_s += period_s
                self.clock.sleep_until(next_s)
                now_s = self.clock.now_s()
                if math.isfinite(last_tick_s):
                    self.periods_s.append(now_s - last_tick_s)
                last_tick_s = now_s
                if self.options.seconds is not None and now_s - start_s >= self.options.seconds:
                    stop_reason = "time limit"
                    break
                if not self.options.control:
                    continue
                t0 = time.perf_counter()
                command = self._command(now_s)
                self.times.add("controller", time.perf_counter() - t0)
                self.sensors.send_command(command)
                self._emit(COMMAND, command, now_s)
                if self.visualiser is not None and shared.map_state is not None:
                    self.visualiser.submit(shared.map_state, shared.plan, command)
                state = self.controller.state
                pose = shared.map_state.pose if shared.map_state is not None else None
                speed = pose.speed_mps if pose is not None else 0.0
                if state in (AsState.FINISHED, AsState.EMERGENCY) and speed < 0.1:
                    standstill_since = standstill_since or now_s
                    if now_s - standstill_since > 1.0:
                        stop_reason = self.controller.stop_reason or state.name.lower()
                        break
                else:
                    standstill_since = None
            if shared.errors:
                stop_reason = "; ".join(shared.errors)
        finally:
            shared.stop.set()
            # Health as the loop last saw it (rates measured once the receivers stop would
            # count the time after the end as silence).
            self._final_health = self.sensors.health(self.clock.now_s())
            self._safe_stop()
            for thread in threads:
                thread.join(1.0)
            self.sensors.stop()
            if self.recorder is not None:
                self.recorder.close()
            if self.visualiser is not None:
                self.visualiser.close()
            for s, handler in previous.items():
                signal.signal(s, handler)
        return self._summary(stop_reason)

    def _command(self, now_s: float) -> ActuatorCommand:
        shared = self.shared
        health = self.sensors.health(now_s)
        map_state = shared.map_state
        if map_state is None:
            return ActuatorCommand(now_s, 0.0, 1.0, 0.0, AsState.READY)
        command: ActuatorCommand = self.controller.command(
            now_s, map_state.pose, shared.plan, health, shared.remote
        )
        if self.recorder is not None and len(self.periods_s) % 10 == 0:
            self.recorder.write(HEALTH, health, now_s)
        return command

    def _safe_stop(self) -> None:
        """Full brake frames for a moment, so the car stops even if nothing else is sent."""
        if not self.options.control:
            return
        for _ in range(5):
            try:
                self.sensors.send_command(ActuatorCommand.full_brake(self.clock.now_s()))
            except Exception:  # the bus may be gone; the car's own watchdog then brakes
                log.exception("could not send the stop command")
                break
            time.sleep(0.01)

    def _summary(self, stop_reason: str) -> dict[str, Any]:
        periods_ms = np.asarray(self.periods_s) * 1e3
        target_ms = 1e3 / self.config.run.control_rate_hz
        timing: dict[str, Any] = {"control_period_target_ms": round(target_ms, 3)}
        if periods_ms.size:
            timing.update({
                "control_period_p99_ms": round(float(np.percentile(periods_ms, 99)), 3),
                "control_period_p50_ms": round(float(np.percentile(periods_ms, 50)), 3),
                "control_period_max_ms": round(float(periods_ms.max()), 3),
                "control_ticks": int(periods_ms.size + 1),
            })
        timing["stages_ms"] = self.times.summary_ms()
        map_state = self.shared.map_state
        summary: dict[str, Any] = {
            "stop_reason": stop_reason,
            "finished": self.controller.state == AsState.FINISHED,
            "laps_completed": self.shared.plan.lap if self.shared.plan is not None else 0,
            "loop_closure": {"closed": bool(map_state is not None and map_state.loop_closed)},
            "landmarks": len(map_state.cones) if map_state is not None else 0,
            "timing": timing,
            "health": [
                {"source": s.source, "rate_hz": round(s.rate_hz, 2), "errors": s.errors,
                 "rejects": dict(s.rejects)}
                for s in self._final_health.sources
            ],
            "outputs_sha256": self.hasher.hexdigest(),
        }
        (self.options.out_dir / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
        return summary
