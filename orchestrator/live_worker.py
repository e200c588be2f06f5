"""The executive and deliberative layers of ``drive``, in a process of their own.

:class:`orchestrator.live.LiveMain` (the reactive layer: control and safety, the CAN bus) starts
this process with ``multiprocessing`` (spawn) so that the heavy layers never share a GIL with
the control loop. Here:

- the Sensor Manager runs the receivers of every enabled source but CAN (GPS, IMU, LiDAR,
  camera); the CAN frames (and their decoded readings) come from the control process with
  every control tick;
- thread ``mapper`` runs the :class:`~orchestrator.layers.ExecutiveLayer` (records the raw
  units, drops stale readings, updates the Mapper) on whatever arrived, keeps each map state's
  pose for the planner to observe, sends each new pose to the control process and steps the
  :class:`~orchestrator.layers.OutputLayer` (map states to the recording, frames);
- the :class:`~orchestrator.layers.DeliberativeLayer` (the planner) runs in a process of its
  own, :mod:`orchestrator.live_planner`, started here; thread ``planner`` answers its requests
  for the newest map and sends each plan it makes on to the control process and the recording;
- thread ``health`` sends the sensors' health at :data:`HEALTH_RATE_HZ`;
- the recording is written by a process of its own too, :mod:`orchestrator.live_recorder`
  (the layers hand it their messages as they would the recorder);
- the main thread takes the control process's messages: CAN frames for the mapper, commands and
  health for the recording, :class:`~orchestrator.layer_messages.Stop`.

The layers are the objects ``Main.tick`` steps in simulation and replay; the messages are those
of :mod:`orchestrator.layer_messages`.

The process ignores SIGINT and SIGTERM (Ctrl-C reaches the whole process group): the control
process decides when the run ends. It ends on ``stop``, on an error in one of its layers, or when
the link closes (the control process died); it then joins its threads, stops the receivers,
closes the recording and the visualiser, and sends its final statistics.
"""

from __future__ import annotations

import dataclasses
import gc
import logging
import multiprocessing as mp
import resource
import socket
import threading
import time
import traceback
from collections import deque
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from common.clock import RealClock
from common.messages import (
    ActuatorCommand,
    AsState,
    CanFrame,
    Plan,
    PoseEstimate,
    RawBytes,
    Reading,
    RemoteStop,
)
from orchestrator.config import AppConfig
from orchestrator.layer_messages import (
    ControlTick,
    Final,
    HealthUpdate,
    LayerError,
    Loaded,
    MapRequest,
    PlannerInput,
    PlanUpdate,
    PoseUpdate,
    Start,
    Stop,
)
from orchestrator.layers import ExecutiveLayer, OutputLayer
from orchestrator.live_link import Link, link_pair
from orchestrator.live_planner import PlannerServer, planner_main, planner_niceness
from orchestrator.live_recorder import RecorderProcess, recorder_niceness
from orchestrator.main_loop import StageTimes
from orchestrator.outputs import HashSink
from orchestrator.priority import enter_child_process, lock_memory
from recordings.topics import COMMAND, PLAN
from sensors.config import SensorsConfig

if TYPE_CHECKING:
    from orchestrator.live import DriveOptions

log = logging.getLogger(__name__)

HEALTH_RATE_HZ = 100.0
"""How often the sensors' health goes to the control process (its staleness check ages it)."""
IDLE_SLEEP_S = 0.002
"""The executive layer's wait when no sensor data came."""
PLANNER_START_TIMEOUT_S = 60.0
"""Longest wait (s) for the planner process to build its layer."""
PLANNER_STOP_TIMEOUT_S = 5.0
"""Longest wait (s) for the planner process's statistics at the end."""
DRIVE_IMU_COALESCE_BACKLOG_S = 0.15
"""``mapper.fusion.imu_coalesce_backlog_s`` in ``drive`` (when 0 in the configuration): a map
update that takes more IMU samples than this long predicts them two at a time. A LiDAR sweep
holds the map back about 0.1 s; on a busy computer one update took 0.3 s of them (issue 19)."""
POSE_BACKLOG = 1000
"""Poses kept for the planner to observe between its requests (about 10 s of map updates)."""


def worker_sensors(config: AppConfig) -> SensorsConfig:
    """The sensors section of the worker's Sensor Manager: every source but CAN."""
    return dataclasses.replace(config.sensors,
                               can=dataclasses.replace(config.sensors.can, enabled=False))


def control_sensors(config: AppConfig) -> SensorsConfig:
    """The sensors section of the control process's Sensor Manager: CAN alone."""
    sc = config.sensors
    off = {name: dataclasses.replace(getattr(sc, name), enabled=False)
           for name in ("gps", "imu", "lidar", "camera")}
    return dataclasses.replace(sc, **off)


def _merge_by_time(a: list[Any], b: list[Any]) -> list[Any]:
    """Two time-ordered lists merged in time order (ties: ``a`` first)."""
    if not b:
        return a
    if not a:
        return b
    merged = a + b
    merged.sort(key=lambda r: float(r.timestamp_s))  # stable: a's ties stay first
    return merged


class Worker:
    """The executive layer, its sensors, the recording and the visualiser, and the link to the
    planner's process (``planner_in_thread``: the planner served from a thread of this process
    instead, over the same link, for tests)."""

    def __init__(self, config: AppConfig, options: DriveOptions, clock: RealClock,
                 link: Link, planner_in_thread: bool = False) -> None:
        from orchestrator.managers import make_sensors

        self.config = config
        self.options = options
        self.clock = clock
        self.link = link
        self.sensors = make_sensors(config, clock, worker_sensors(config))
        if config.mapper.fusion.imu_coalesce_backlog_s == 0.0:
            config.mapper.fusion.imu_coalesce_backlog_s = DRIVE_IMU_COALESCE_BACKLOG_S
        self.hasher = HashSink()
        self.recorder: Any = None
        self.visualiser: Any = None
        self.live: Any = None
        self.planner_link: Link | None = None
        self.planner_process: Any = None
        self.planner_server: PlannerServer | None = None
        """The planner served from a thread (``planner_in_thread``), else None."""
        self._planner_thread: threading.Thread | None = None
        self.planner_stats: dict[str, Any] = {}
        self._poses: deque[PoseEstimate] = deque(maxlen=POSE_BACKLOG)
        self._plan: Plan | None = None
        try:
            self._build_layers(planner_in_thread)
        except BaseException:
            # the processes started so far wait for their links: end them, or this process
            # would wait for them at its exit
            self._close_outputs()
            raise
        self.times = StageTimes()
        self.stop = threading.Event()
        self.errors: list[str] = []
        self._can: deque[tuple[tuple[CanFrame | RawBytes, ...], tuple[Reading, ...]]] = deque()
        self._can_lock = threading.Lock()
        self.command: ActuatorCommand | None = None
        self.remote: RemoteStop | None = None
        self.gc_times: GcTimes | None = None
        self.memory_locked = False
        """Whether this process's memory is locked in RAM (drive in real-time mode)."""

    def _build_layers(self, planner_in_thread: bool) -> None:
        """The recorder's and the planner's processes, the visualiser, the live view and the
        executive and output layers."""
        from orchestrator.managers import make_mapper
        from orchestrator.outputs import start_live

        config, options = self.config, self.options
        if options.record:
            self.recorder = RecorderProcess(options.out_dir / options.recording_name,
                                            config.recording,
                                            recorder_niceness(options.executive_niceness),
                                            logging.getLogger().getEffectiveLevel())
        if options.render and options.control:
            from visualiser.visualiser import Visualiser

            self.visualiser = Visualiser(config.visualiser, options.out_dir / "frames",
                                         laps=config.mission.laps)
        self.live = start_live(options.live, config)
        run = config.run
        self.executive = ExecutiveLayer(make_mapper(config) if options.control else None,
                                        run.stale_input_s, self.recorder, self.live)
        if options.control:
            self._start_planner(planner_in_thread)
        sinks = [self.hasher] + ([self.recorder] if self.recorder is not None else [])
        self.output = OutputLayer(sinks, run.output_record_rate_hz, config.visualiser.fps,
                                  self.recorder, self.visualiser, self.live)

    def _close_outputs(self) -> None:
        """Close the recording, the live view, the visualiser and the planner, each guarded."""
        for name, close in (("recorder", getattr(self.recorder, "close", None)),
                            ("live view", getattr(self.live, "close", None)),
                            ("visualiser", getattr(self.visualiser, "close", None)),
                            ("planner", self._stop_planner)):
            if close is None:
                continue
            try:
                close()
            except Exception:
                log.exception("closing the %s failed", name)

    @property
    def plan(self) -> Plan | None:
        """The planner's last plan (None before the first, or record-only)."""
        return self._plan

    # ------------------------------------------------------------------ the planner's process
    def _start_planner(self, in_thread: bool) -> None:
        ours, theirs = link_pair()
        if in_thread:
            self.planner_server = PlannerServer(self.config, Link(theirs), self.clock)
            self._planner_thread = threading.Thread(target=self.planner_server.run,
                                                    name="planner-server", daemon=True)
            self._planner_thread.start()
        else:
            # not a daemon: it starts the racing line's process
            self.planner_process = mp.get_context("spawn").Process(
                target=planner_main, name="fsd-planner",
                args=(self.config, theirs, logging.getLogger().getEffectiveLevel(),
                      planner_niceness(self.options.executive_niceness),
                      self.options.realtime_priority > 0))
            self.planner_process.start()
            theirs.close()
        self.planner_link = Link(ours)

    def _planner_loaded(self) -> bool:
        """Wait until the planner has built its layer; False (the error sent) if it did not."""
        link = self.planner_link
        if link is None:
            return True
        end = time.monotonic() + PLANNER_START_TIMEOUT_S
        while not link.closed and time.monotonic() < end:
            for message in link.recv(0.05):
                if isinstance(message, Loaded):
                    return True
                if isinstance(message, LayerError):
                    self._report(message.text)
                    return False
        self._report("planner: the planner process did not start")
        return False

    def _recorder_started(self) -> bool:
        """Wait until the recording is open; False (the error sent) if it could not be."""
        if self.recorder is None:
            return True
        error = self.recorder.wait_started()
        if error is not None:
            self._report(error)
            return False
        return True

    def _report(self, text: str) -> None:
        """An error of the run: logged, sent to the control process, and the run stops."""
        log.error("%s", text)
        self.errors.append(text)
        self.link.send(LayerError(text))
        self.stop.set()

    def _stop_planner(self) -> None:
        """Stop the planner, take its statistics, and end its process or thread."""
        link = self.planner_link
        if link is None:
            return
        link.send(Stop())
        end = time.monotonic() + PLANNER_STOP_TIMEOUT_S
        while not self.planner_stats and not link.closed and time.monotonic() < end:
            for message in link.recv(0.1):
                if isinstance(message, Final):
                    self.planner_stats = message.stats
        link.close()
        if self.planner_process is not None:
            self.planner_process.join(PLANNER_STOP_TIMEOUT_S)
            if self.planner_process.is_alive():
                log.error("the planner process did not end: killing it")
                self.planner_process.kill()
                self.planner_process.join(PLANNER_STOP_TIMEOUT_S)
        if self._planner_thread is not None:
            self._planner_thread.join(PLANNER_STOP_TIMEOUT_S)

    def _fail(self, layer: str, exc: BaseException) -> None:
        log.exception("%s layer failed", layer)
        text = f"{layer}: {exc!r}"
        self.errors.append(text)
        self.link.send(LayerError(text))
        self.stop.set()

    # ------------------------------------------------------------------ layers
    def _take_can(self) -> tuple[list[CanFrame | RawBytes], list[Reading]]:
        with self._can_lock:
            items = list(self._can)
            self._can.clear()
        raw: list[CanFrame | RawBytes] = []
        readings: list[Reading] = []
        for r, p in items:
            raw.extend(r)
            readings.extend(p)
        return raw, readings

    def _executive(self) -> None:
        while not self.stop.is_set():
            try:
                batch = self.sensors.take()
                can_raw, can_readings = self._take_can()
                if not batch.raw and not can_raw:
                    time.sleep(IDLE_SLEEP_S)
                    continue
                now_s = self.clock.now_s()
                raw = _merge_by_time(list(batch.raw), can_raw)
                readings = self.executive.admit(
                    now_s, raw, _merge_by_time(list(batch.readings), can_readings))
                if self.executive.mapper is None:
                    continue  # record only
                t0 = time.perf_counter()
                map_state = self.executive.step(now_s, readings)
                self.times.add("mapper", time.perf_counter() - t0)
                self.link.send(PoseUpdate(map_state.pose, map_state.loop_closed,
                                          len(map_state.cones)))
                self._poses.append(map_state.pose)  # the planner observes them all
                self.output.step(now_s, map_state, self.plan, self.command)
            except Exception as exc:  # a crash here must stop the car, never go silent
                self._fail("mapper", exc)

    def _deliberative(self) -> None:
        """Serve the planner's process: the newest map when it asks, its plans on to the
        control process and the recording."""
        link = self.planner_link
        assert link is not None
        while not self.stop.is_set():
            for message in link.recv(0.05):
                self._on_planner_message(message)
            if link.closed and not self.stop.is_set():
                self._report("planner: the planner process is gone")

    def _on_planner_message(self, message: Any) -> None:
        link = self.planner_link
        assert link is not None
        if isinstance(message, MapRequest):
            poses: list[PoseEstimate] = []
            while self._poses:
                poses.append(self._poses.popleft())
            go = self.remote is not None and self.remote.go
            driving = self.command is not None and self.command.state == AsState.DRIVING
            link.send(PlannerInput(self.executive.map_state, tuple(poses), go, driving))
        elif isinstance(message, PlanUpdate):
            self._plan = message.plan
            self.link.send(message)
            self.output.emit(PLAN, message.plan, message.plan.timestamp_s)
        elif isinstance(message, LayerError):
            self._report(message.text)
        elif isinstance(message, Final):
            self.planner_stats = message.stats
        else:
            log.warning("unknown message from the planner process: %r", type(message).__name__)

    def _health(self) -> None:
        period_s = 1.0 / HEALTH_RATE_HZ
        next_s = self.clock.now_s()
        while not self.stop.is_set():
            try:
                next_s += period_s
                self.clock.sleep_until(next_s)
                health = self.sensors.health(self.clock.now_s())
                if not self.link.send(HealthUpdate(health)):
                    break
            except Exception as exc:
                self._fail("health", exc)

    # ------------------------------------------------------------------ control messages
    def _on_message(self, message: Any) -> None:
        if isinstance(message, ControlTick):
            if message.can_raw or message.can_readings:
                for reading in message.can_readings:
                    if isinstance(reading, RemoteStop):
                        self.remote = reading
                with self._can_lock:
                    self._can.append((message.can_raw, message.can_readings))
            if message.command is not None:
                self.command = message.command
                self.output.emit(COMMAND, message.command, message.now_s)
            if message.health is not None:
                self.output.write_health(message.health, message.now_s)
        elif isinstance(message, Stop):
            self.stop.set()
        else:
            log.warning("unknown message from the control process: %r", type(message).__name__)

    def _guarded(self, layer: str, body: Callable[[], None]) -> None:
        """Run a layer's thread body; whatever escapes it stops the run, reported."""
        try:
            body()
        except BaseException as exc:
            self._fail(layer, exc)

    def _start(self, clock: RealClock) -> None:
        """Take the run's clock (it starts with the sensors) and start the receivers."""
        self.clock = clock
        from orchestrator.managers import make_sensors

        self.sensors = make_sensors(self.config, clock, worker_sensors(self.config))
        self.sensors.start()
        if self.planner_link is not None:
            self.planner_link.send(Start(clock))

    def run(self) -> None:
        """Start the layers, serve the control process until the end, then shut down."""
        layers = [("mapper", self._executive), ("health", self._health)]
        if self.planner_link is not None:
            layers.append(("planner", self._deliberative))
        threads = [threading.Thread(target=self._guarded, args=(name, body), name=name,
                                    daemon=True) for name, body in layers]
        # Everything built so far (modules, the layers) lives until the end: out of the
        # collector's sight, so its full collections (which hold the GIL) stay short.
        gc.collect()
        gc.freeze()
        if self.options.realtime_priority > 0:
            self.memory_locked = lock_memory("executive process")
        self.gc_times = GcTimes()
        gc.callbacks.append(self.gc_times)
        # a planner that did not start stops the run (the error is sent): the layers are shut
        # down below as after any other error, and the statistics sent
        if self._recorder_started() and self._planner_loaded():
            self.link.send(Loaded())
        started = False
        try:
            while not self.stop.is_set() and not started:
                for message in self.link.recv(0.05):
                    if isinstance(message, Start):
                        self._start(message.clock)
                        started = True
                    else:
                        self._on_message(message)
                if self.link.closed:
                    self.stop.set()
            for thread in threads if started else ():
                thread.start()
            while not self.stop.is_set():
                for message in self.link.recv(0.05):
                    self._on_message(message)
                if self.link.closed:
                    log.error("the control process is gone: stopping")
                    self.stop.set()
            # what the control process sent before it asked to stop (last commands, health)
            for message in self.link.poll():
                if isinstance(message, ControlTick):
                    self._on_message(message)
        except Exception as exc:
            self._fail("executive", exc)
        finally:
            self.stop.set()
            for thread in threads:
                if thread.is_alive():
                    thread.join(2.0)
            try:
                self.sensors.stop()
            except Exception:
                log.exception("closing the sensors failed")
            self._close_outputs()
        stats: dict[str, Any] = {
            "stages_ms": {**self.times.summary_ms(),
                          **self.planner_stats.get("stages_ms", {})},
            "lags_ms": self._lags_ms(),
            "outputs_sha256": self.hasher.hexdigest(),
            "errors": self.errors,
            "memory_locked": self.memory_locked,
            "major_page_faults": resource.getrusage(resource.RUSAGE_SELF).ru_majflt,
        }
        if self.gc_times is not None:
            stats["gc_ms"] = self.gc_times.summary_ms()
        if self.recorder is not None:
            stats["recording_dropped"] = int(getattr(self.recorder, "dropped", 0))
        if self.live is not None:
            stats["live"] = self.live.stats()
        if self.visualiser is not None:
            stats["frames"] = {"submitted": self.visualiser.submitted,
                               "dropped": self.visualiser.dropped}
        self.link.send(Final(stats))

    def _lags_ms(self) -> dict[str, dict[str, float]]:
        """The executive's lag behind its sensors, the planner's and the outputs' behind
        their rates (ms)."""
        lags = {"mapper": self.executive.summary_ms(),
                "outputs": self.output.output_rate.summary_ms()}
        lags.update(self.planner_stats.get("lags_ms", {}))
        return lags


class GcTimes:
    """Pauses of the cyclic garbage collector (they hold the GIL: every thread waits)."""

    def __init__(self) -> None:
        self.times = StageTimes()
        self._t0 = 0.0

    def __call__(self, phase: str, info: dict[str, int]) -> None:
        if phase == "start":
            self._t0 = time.perf_counter()
        else:
            self.times.add(f"gc{info.get('generation', 0)}", time.perf_counter() - self._t0)

    def summary_ms(self) -> dict[str, dict[str, float]]:
        return self.times.summary_ms()


def worker_main(config: AppConfig, options: DriveOptions, clock: RealClock,
                sock: socket.socket, log_level: int) -> None:
    """Entry point of the worker process (``multiprocessing`` spawn target)."""
    enter_child_process("executive process", log_level, options.executive_niceness)
    link = Link(sock)
    try:
        worker = Worker(config, options, clock, link)
    except Exception as exc:
        log.exception("the executive process could not start")
        link.send(LayerError(f"executive start: {exc!r}"))
        link.send(Final({"errors": [traceback.format_exc(limit=3)]}))
        link.close()
        return
    try:
        worker.run()
    finally:
        link.close()
