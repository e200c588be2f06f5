"""Main on the car: the reactive layer in this process, the heavy layers in another.

- Reactive layer (this module, the calling thread of the ``drive`` process): every
  1 / control_rate_hz on the wall clock it takes the CAN frames (the RES among them: an
  emergency stop reaches control directly), reads the latest pose, plan and health, asks the
  Controller for a command and sends it on CAN. The only other thread of this process is the
  CAN receiver, so nothing heavy shares its GIL; it never waits for the other layers: their
  results arrive as messages it drains without blocking (:mod:`orchestrator.live_link`).
- Executive layer (sensor receivers and parsing, the Mapper, recording, rendering) runs in a
  separate process, :mod:`orchestrator.live_worker` (``multiprocessing``, spawn), and starts
  the deliberative layer (the planner) in a third, :mod:`orchestrator.live_planner`. This
  process forwards the CAN frames and its commands to the executive each tick; it sends back
  each pose, each plan (the planner's, sent on) and the sensors' health.

A source's health comes with the time it was measured; here its age is advanced to now, so a
stalled or dead executive process makes its sources stale (the safety supervisor stops the car).
An error in either process, or the executive process dying, ends the run with a safe stop.

Timing: the control thread and the CAN receiver run at SCHED_FIFO priority when the system
allows it (``drive --rt-priority N``, default 10, 0 for none), so a busy machine cannot delay a
tick's wake-up; both processes freeze their start-up heap (``gc.freeze``) so that the garbage
collector's full passes, which hold the GIL, stay short. The summary reports the period's
percentiles, how late each tick woke (``control_wake_late_p99_ms``) and the GC pauses.

Ctrl-C and SIGTERM end the run cleanly: the car is commanded to stop (full brake frames), the
executive process is told to stop (it joins its threads and closes the recording and the
visualiser) and joined, the CAN receiver is stopped.
"""

from __future__ import annotations

import gc
import json
import logging
import math
import multiprocessing as mp
import os
import resource
import signal
import sys
import threading
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from common.clock import RealClock
from common.messages import (
    ActuatorCommand,
    AsState,
    Health,
    Plan,
    PoseEstimate,
    SourceHealth,
)
from orchestrator.config import AppConfig, apply_mission
from orchestrator.layer_messages import (
    ControlTick,
    Final,
    HealthUpdate,
    LayerError,
    Loaded,
    PlanUpdate,
    PoseUpdate,
    Start,
    Stop,
)
from orchestrator.layers import ReactiveLayer
from orchestrator.live_link import Link, link_pair
from orchestrator.live_worker import control_sensors, worker_main
from orchestrator.main_loop import StageTimes
from orchestrator.managers import make_controller, make_sensors
from orchestrator.priority import DEFAULT_EXECUTIVE_NICENESS, lock_memory, unlock_memory
from sensors.can_receiver import CanReceiver
from sensors.manager import SOURCES

log = logging.getLogger(__name__)

WORKER_START_TIMEOUT_S = 60.0
"""The executive process must have built its layers within this long."""
WORKER_STOP_TIMEOUT_S = 30.0
"""At the end it must close its recording and send its statistics within this long."""
DEFAULT_REALTIME_PRIORITY = 10
"""SCHED_FIFO priority of the reactive layer (1..99; a modest one, below the kernel's own
real-time threads)."""
CONTROL_SWITCH_INTERVAL_S = 0.0001
"""The control process's interpreter switch interval (s; Python's default is 0.005). The control
loop's wake-up waits for the interpreter lock when a CAN thread holds it, up to this long before
the holder is asked to let go: at 0.5 ms, bench load's wake-up lateness p99 was 0.55-1.48 ms in 5
runs; at 0.1 ms, 0.08-0.42 ms in 19 of 20 and 2.0 ms once (issue 19)."""
HEALTH_RECORD_EVERY = 10
"""Every this many control ticks the health the controller saw is recorded."""


@dataclass
class DriveOptions:
    """``drive`` / ``record`` options."""

    out_dir: Path
    laps: int | None = None
    mission: str | None = None
    """trackdrive or autocross; None: the config's (as ``exploration``)."""
    exploration: str | None = None
    record: bool = True
    control: bool = True
    seconds: float | None = None
    render: bool = False
    recording_name: str = "recording.mcap"
    realtime_priority: int = DEFAULT_REALTIME_PRIORITY
    """SCHED_FIFO priority of the reactive layer (control loop and CAN receiver); 0: none."""
    executive_report_grace_s: float = 0.9
    """How late (s) the executive process's sensor report may be before its sensors count as
    lost (a report that says a sensor is silent counts at once): a busy computer delays the
    map and the plan, which the controller rides out, not the sensors. With the IMU's 0.1 s
    timeout the report may be 1 s late, as long as the controller follows a late plan
    (``controller.safety.plan_max_age_s``); 0.4 s ended runs in EMERGENCY at the handover on a
    loaded 2-core machine, where building the racing line holds the executive (issue 19)."""
    executive_niceness: int = DEFAULT_EXECUTIVE_NICENESS
    """Niceness of the executive process (mapping, planning, recording): ahead of the
    computer's other work, behind the real-time control loop; 0: the default share."""
    live: tuple[str, int] | None = None
    """(host, port) of the Foxglove live view, served by the executive process (``--live``)."""


def set_realtime_priority(priority: int, what: str = "reactive layer"
                          ) -> tuple[int, int] | None:
    """Put the calling thread (and the threads it starts later) under SCHED_FIFO at
    ``priority`` (``what`` names it in the log); returns the policy and priority it had (for
    :func:`restore_priority`), or None, with a warning, when the system does not allow it (it
    needs root, CAP_SYS_NICE or an ``rtprio`` limit) or ``priority`` is 0.

    The control loop sleeps most of each period; at real-time priority a busy machine cannot
    delay its wake-up (the kernel still keeps 5 % of the CPU for the rest by default).
    """
    if priority <= 0:
        return None
    if not hasattr(os, "sched_setscheduler"):
        log.warning("no real-time scheduling on this system: the %s's timing depends on "
                    "the load", what)
        return None
    try:
        previous = (os.sched_getscheduler(0), os.sched_getparam(0).sched_priority)
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(priority))
    except (OSError, ValueError) as exc:
        log.warning("real-time priority %d refused (%s): the %s's timing depends on the "
                    "load (run as root, with CAP_SYS_NICE, or raise the rtprio limit)",
                    priority, exc, what)
        return None
    log.info("%s at SCHED_FIFO priority %d", what, priority)
    return previous


def restore_priority(previous: tuple[int, int] | None) -> None:
    """Undo :func:`set_realtime_priority` for the calling thread."""
    if previous is None:
        return
    try:
        os.sched_setscheduler(0, previous[0], os.sched_param(previous[1]))
    except (OSError, ValueError) as exc:
        log.warning("could not restore the scheduling policy: %s", exc)


def merge_health(now_s: float, own: Health, remote: Health | None,
                 remote_sources: Sequence[str], timeouts_s: dict[str, float],
                 report_grace_s: float = 0.0) -> Health:
    """One :class:`Health` at ``now_s`` from this process's sources (``own``: CAN and RES)
    and the executive process's (``remote``, measured at ``remote.timestamp_s``).

    The remote sources' ages are advanced to ``now_s``. A source is stale when the report says
    so (its receiver saw the sensor silent: :meth:`sensors.manager.SensorManager.health`), or
    its age now exceeds ``timeouts_s[source]`` by more than ``report_grace_s`` (the report
    itself is late: a busy executive process is given that long before its sensors count as
    lost). A remote source with no report yet is
    stale. Sources come in the Sensor Manager's order (``res`` after ``can``).
    """
    by_source: dict[str, SourceHealth] = {s.source: s for s in own.sources}
    reported = {s.source: s for s in remote.sources} if remote is not None else {}
    lag_s = max(0.0, now_s - remote.timestamp_s) if remote is not None else math.inf
    for source in remote_sources:
        s = reported.get(source)
        if s is None:
            by_source[source] = SourceHealth(now_s, source, False, 0.0, math.inf, 0, True)
            continue
        age_s = s.age_s + lag_s
        stale = s.stale or age_s > timeouts_s[source] + report_grace_s
        by_source[source] = SourceHealth(now_s, source, s.alive, s.rate_hz, age_s, s.errors,
                                         stale, s.rejects)
    order = [name for source in SOURCES for name in
             ((source, "res") if source == "can" else (source,))]
    ordered = [by_source.pop(name) for name in order if name in by_source]
    ordered.extend(by_source.values())
    return Health(now_s, tuple(ordered), own.state, own.stop_reason)


class LiveMain:
    """Main for the car: the control loop here, the executive and deliberative layers in a
    process of their own (:mod:`orchestrator.live_worker`)."""

    def __init__(self, config: AppConfig, options: DriveOptions) -> None:
        self.config = config
        self.options = options
        apply_mission(config.mission, options.laps, options.mission, options.exploration)
        self.clock = RealClock()
        self.sensors = make_sensors(config, self.clock, control_sensors(config))
        self.reactive = ReactiveLayer(make_controller(config), config.run.control_rate_hz,
                                      config.mission.mission)
        self.controller = self.reactive.controller
        options.out_dir.mkdir(parents=True, exist_ok=True)
        sc = config.sensors
        self.remote_sources = tuple(s for s in SOURCES
                                    if s != "can" and getattr(sc, s).enabled)
        self.timeouts_s = {s: float(getattr(sc, s).timeout_s) for s in SOURCES}
        self.times = StageTimes()
        self.periods_s: list[float] = []
        self.wake_late_s: list[float] = []
        """How late each tick woke after its scheduled time (s)."""
        self.errors: list[str] = []
        self.pose: PoseEstimate | None = None
        self.plan: Plan | None = None
        self.loop_closed = False
        self.landmarks = 0
        self.worker_health: Health | None = None
        self.worker_stats: dict[str, Any] = {}
        self.worker_loaded = False
        self.realtime = False
        self.memory_locked = False
        """Whether this process's memory is locked in RAM (real-time mode, when allowed)."""
        self.gc_times = StageTimes()
        self._gc_t0 = 0.0
        self.stop = threading.Event()
        self._link: Link | None = None
        self._process: Any = None
        self._final_health: Health | None = None

    # ------------------------------------------------------------------ the executive process
    def _gc_callback(self, phase: str, info: dict[str, int]) -> None:
        if phase == "start":
            self._gc_t0 = time.perf_counter()
        else:
            self.gc_times.add(f"gc{info.get('generation', 0)}", time.perf_counter() - self._gc_t0)

    def _start_worker(self) -> None:
        parent_sock, child_sock = link_pair()
        ctx = mp.get_context("spawn")
        self._process = ctx.Process(
            # not a daemon: it starts the visualiser's process; it ends by itself when the
            # link closes, and _stop_worker always joins it
            target=worker_main, name="fsd-executive",
            args=(self.config, self.options, self.clock, child_sock,
                  logging.getLogger().getEffectiveLevel()),
        )
        self._process.start()
        child_sock.close()
        self._link = Link(parent_sock)

    def _on_message(self, message: Any) -> None:
        if isinstance(message, PoseUpdate):
            self.pose, self.loop_closed, self.landmarks = (message.pose, message.loop_closed,
                                                           message.landmarks)
        elif isinstance(message, PlanUpdate):
            self.plan = message.plan
        elif isinstance(message, HealthUpdate):
            self.worker_health = message.health
        elif isinstance(message, Loaded):
            self.worker_loaded = True
        elif isinstance(message, LayerError):
            log.error("executive process: %s", message.text)
            self.errors.append(message.text)
        elif isinstance(message, Final):
            self.worker_stats = message.stats
        else:
            log.warning("unknown message from the executive process: %r",
                        type(message).__name__)

    def _drain(self) -> None:
        """Take every message the executive process sent; note it if it is gone."""
        assert self._link is not None
        for message in self._link.poll():
            self._on_message(message)
        if self._link.closed and not self.worker_stats and not self.errors:
            code = self._process.exitcode if self._process is not None else None
            self.errors.append(f"executive process died (exit code {code})")
            log.error("the executive process died (exit code %s)", code)

    def _wait_loaded(self) -> bool:
        """Wait until the executive process has built its layers (it starts its sensors when
        told to)."""
        end = time.monotonic() + WORKER_START_TIMEOUT_S
        while not self.stop.is_set() and not self.errors:
            self._drain()
            if self.worker_loaded:
                return True
            if time.monotonic() > end:
                self.errors.append(
                    f"executive process not ready within {WORKER_START_TIMEOUT_S:.0f} s")
                break
            time.sleep(0.02)
        return False

    def _stop_worker(self) -> None:
        link, process = self._link, self._process
        if link is None or process is None:
            return
        link.send_nowait(Stop())
        end = time.monotonic() + WORKER_STOP_TIMEOUT_S
        while not link.closed and not self.worker_stats and time.monotonic() < end:
            link.flush()
            for message in link.poll():
                self._on_message(message)
            time.sleep(0.01)
        process.join(max(1.0, end - time.monotonic()))
        for message in link.poll():  # what it sent before it went (a send error closes early)
            self._on_message(message)
        if process.is_alive():
            # it ignores SIGTERM (the control process decides when it ends): SIGKILL. Its
            # recorder's process then sees its link close and finishes the file.
            log.error("the executive process did not end: killing it")
            process.kill()
            process.join(2.0)
        link.close()

    # ------------------------------------------------------------------ the reactive loop
    def run(self) -> dict[str, Any]:
        """Drive until finished, a stop, ``seconds`` or a signal; returns the summary."""
        previous = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}

        def on_signal(signum: int, _frame: Any) -> None:
            log.warning("signal %d: stopping the car", signum)
            self.stop.set()

        for s in previous:
            signal.signal(s, on_signal)
        previous_switch_s = sys.getswitchinterval()
        sys.setswitchinterval(CONTROL_SWITCH_INTERVAL_S)
        stop_reason = "signal"
        previous_policy: tuple[int, int] | None = None
        try:
            self._start_worker()
            if self._wait_loaded():
                gc.collect()
                gc.freeze()  # what is built lives to the end: keep full collections short
                gc.callbacks.append(self._gc_callback)
                # The run's clock starts now, with the sensors (a sensor stamping its own time,
                # as the camera does, counts from when the stack opened the bus).
                self.clock = RealClock()
                self.sensors = make_sensors(self.config, self.clock, control_sensors(self.config))
                assert self._link is not None
                self._link.send_nowait(Start(self.clock))
                previous_policy = set_realtime_priority(self.options.realtime_priority)
                self.realtime = previous_policy is not None
                if self.options.realtime_priority > 0:
                    self.memory_locked = lock_memory("control process")
                self.sensors.start()  # the CAN receiver thread inherits the priority
                stop_reason = self._loop()
            if self.errors:
                stop_reason = "; ".join(self.errors)
        finally:
            self.stop.set()
            # Health as the loop last saw it (rates measured once the receivers stop would
            # count the time after the end as silence).
            self._final_health = self._health(self.clock.now_s())
            self._safe_stop()
            self._stop_worker()
            self.sensors.stop()
            for s, handler in previous.items():
                signal.signal(s, handler)
            if self._gc_callback in gc.callbacks:
                gc.callbacks.remove(self._gc_callback)
            gc.unfreeze()
            sys.setswitchinterval(previous_switch_s)
            restore_priority(previous_policy)
            if self.memory_locked:
                unlock_memory()
        return self._summary(stop_reason)

    def _loop(self) -> str:
        assert self._link is not None
        link = self._link
        period_s = 1.0 / self.config.run.control_rate_hz
        start_s = self.clock.now_s()
        next_s = start_s
        last_tick_s = math.nan
        standstill_since: float | None = None
        ticks = 0
        while not self.stop.is_set():
            next_s += period_s
            self.clock.sleep_until(next_s)
            now_s = self.clock.now_s()
            self.wake_late_s.append(now_s - next_s)
            if math.isfinite(last_tick_s):
                self.periods_s.append(now_s - last_tick_s)
            last_tick_s = now_s
            if self.options.seconds is not None and now_s - start_s >= self.options.seconds:
                return "time limit"
            t0 = time.perf_counter()
            self._drain()
            if self.errors:
                return "; ".join(self.errors)
            batch = self.sensors.take()
            self.reactive.take(batch.readings)  # the RES and MISSION_SELECT
            t1 = time.perf_counter()
            command: ActuatorCommand | None = None
            health: Health | None = None
            if self.options.control:
                health = self._health(now_s)
                command = self.reactive.step(now_s, self.pose, self.plan, health)
                self.sensors.send_command(command)
                self.sensors.report_status(self.reactive.as_status(now_s))
                self.times.add("controller", time.perf_counter() - t1)
            t2 = time.perf_counter()
            record_health = health if ticks % HEALTH_RECORD_EVERY == 0 else None
            ticks += 1
            if batch.raw or batch.readings or command is not None:
                link.send_nowait(ControlTick(now_s, tuple(batch.raw), tuple(batch.readings),
                                             command, record_health))
            else:
                link.flush()
            self.times.add("link", (t1 - t0) + (time.perf_counter() - t2))
            if not self.options.control:
                continue
            state = self.controller.state
            speed = self.pose.speed_mps if self.pose is not None else 0.0
            if state in (AsState.FINISHED, AsState.EMERGENCY) and speed < 0.1:
                standstill_since = standstill_since or now_s
                if now_s - standstill_since > 1.0:
                    return self.controller.stop_reason or state.name.lower()
            else:
                standstill_since = None
        return "signal"

    def _health(self, now_s: float) -> Health:
        return merge_health(now_s, self.sensors.health(now_s), self.worker_health,
                            self.remote_sources, self.timeouts_s,
                            self.options.executive_report_grace_s)

    def _safe_stop(self) -> None:
        """Full brake frames for a moment, so the car stops even if nothing else is sent."""
        if not self.options.control or not self.sensors.receivers:
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
        for name, ages in (("plan_age", self.reactive.plan_ages_s),
                           ("map_age", self.reactive.pose_ages_s)):
            if ages:
                ages_ms = np.asarray(ages) * 1e3
                timing[f"{name}_p99_ms"] = round(float(np.percentile(ages_ms, 99)), 3)
                timing[f"{name}_max_ms"] = round(float(ages_ms.max()), 3)
        timing["realtime_priority"] = self.options.realtime_priority if self.realtime else None
        timing["memory_locked"] = {"control": self.memory_locked,
                                   "executive": bool(self.worker_stats.get("memory_locked"))}
        # a page read back from disk stalls its thread (tens to hundreds of ms on a busy computer)
        timing["major_page_faults"] = {
            "control": resource.getrusage(resource.RUSAGE_SELF).ru_majflt,
            "executive": self.worker_stats.get("major_page_faults")}
        if self.wake_late_s:
            late_ms = np.asarray(self.wake_late_s) * 1e3
            timing["control_wake_late_p99_ms"] = round(float(np.percentile(late_ms, 99)), 3)
        stages = self.times.summary_ms()
        stages.update(self.worker_stats.get("stages_ms", {}))
        timing["stages_ms"] = stages
        timing["lags_ms"] = {"controller": self.reactive.rate.summary_ms(),
                             **self.worker_stats.get("lags_ms", {})}
        can_receiver = self.sensors.receivers.get("can")
        if isinstance(can_receiver, CanReceiver):
            timing["can_send"] = can_receiver.send_stats()
        link = self._link
        if link is not None:
            timing["link_messages"] = {"sent": link.sent, "received": link.received,
                                       "dropped": link.dropped}
        health = self._final_health
        machine = self.controller.as_machine
        summary: dict[str, Any] = {
            "stop_reason": stop_reason,
            "as_state": machine.state.name,
            "as_off_reason": "; ".join(machine.blockers) if machine.state == AsState.OFF else "",
            "as_transitions": [
                {"time_s": round(t, 3), "from": a.name, "to": b.name, "reason": why}
                for t, a, b, why in machine.transitions],
            "finished": self.controller.state == AsState.FINISHED,
            "laps_completed": self.plan.lap if self.plan is not None else 0,
            "loop_closure": {"closed": bool(self.loop_closed)},
            "landmarks": int(self.landmarks),
            "timing": timing,
            "health": [
                {"source": s.source, "rate_hz": round(s.rate_hz, 2), "errors": s.errors,
                 "rejects": dict(s.rejects)}
                for s in (health.sources if health is not None else ())
            ],
            "outputs_sha256": self.worker_stats.get("outputs_sha256"),
        }
        timing["control_gc_ms"] = self.gc_times.summary_ms()
        if "gc_ms" in self.worker_stats:
            timing["executive_gc_ms"] = self.worker_stats["gc_ms"]
        if "frames" in self.worker_stats:
            summary["frames"] = self.worker_stats["frames"]
        if "live" in self.worker_stats:
            summary["live"] = self.worker_stats["live"]
        (self.options.out_dir / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
        from orchestrator.report import write_report

        write_report(self.options.out_dir, summary, title="drive")
        return summary
