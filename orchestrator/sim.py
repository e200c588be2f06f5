"""The closed-loop simulation run (``python main.py sim``, the default of ``python main.py``).

Phases, as on the car (ARCHITECTURE.md, "Phases of a run"):

1. The simulated car selects the run's mission in ``MISSION_SELECT`` (CAN, 10 Hz); the stack's
   AS state machine leaves OFF for READY with it (a missing or unknown mission keeps it OFF:
   the run ends after ``run.ready_timeout_s`` with the machine's reason).
2. Exploration (``--exploration manual``): the scripted driver (the person, on the car) drives
   one lap and a little past the start line while the stack maps and records waypoints; the
   stack's commands are not applied. Autonomous exploration skips this.
3. The car stands still; once the ASSI (the car decodes the stack's ``AS_STATUS``, 10 Hz and on
   every change) has shown READY for the rules' 5 s, the simulated RES sends "go" over CAN: DRIVING,
   and 3 s later the stack drives its laps (the first timed from then).
4. The controller stops the car at the end of its laps (FINISHED), or earlier on any fault
   (EMERGENCY).

The stack only ever sees the raw bytes the simulated sensors emit, which are recorded, so a
replay of the recording gives the same outputs (``outputs_sha256``) as this run.
"""

from __future__ import annotations

import datetime as dt
import gc
import json
import logging
import math
import os
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from common.clock import RealClock, SimClock
from common.config import config_to_toml
from common.conventions import wrap_angle
from common.errors import RecordingError
from common.messages import ActuatorCommand, AsState, Mission
from orchestrator.config import AppConfig, apply_mission
from orchestrator.live_recorder import RecorderProcess, recorder_niceness
from orchestrator.main_loop import Main
from orchestrator.managers import make_controller, make_mapper, make_planner, make_sensors
from orchestrator.mission_result import mission_timer
from orchestrator.outputs import HashSink, start_live
from orchestrator.progress import LINE_PERIOD_S, Progress, realtime_status
from orchestrator.run_log import RunLog
from orchestrator.sim_summary import sim_summary
from recordings import fsd_pb2
from recordings.topics import EVAL_POSE_ERROR, TRUTH_POSE, TRUTH_TRACK
from simulator.driver import ScriptedDriver
from simulator.faults import parse_fault
from simulator.handover import Handover, Phase
from simulator.track import Track
from simulator.tracks import load_track
from simulator.world import SimWorld

log = logging.getLogger(__name__)
progress_log = logging.getLogger("progress")
PROGRESS_LINE_S = LINE_PERIOD_S
"""Wall time (s) between two plain progress lines when stderr is not a terminal."""


@dataclass
class SimOptions:
    """What the ``sim`` command line asks for (None: the configuration's value)."""

    track: str | None = None
    laps: int | None = None
    mission: str | None = None
    """``trackdrive``, ``autocross``, ``acceleration`` or ``skidpad`` (None: the config's)."""
    exploration: str | None = None
    """``autonomous`` or ``manual`` (None: the config's); autocross is always autonomous."""
    seed: int | None = None
    mapper: str | None = None
    out_dir: Path | None = None
    render: bool | None = None
    record: bool | None = None
    realtime: bool = False
    faults: list[str] = field(default_factory=list)
    progress: bool = False
    live: tuple[str, int] | None = None
    """(host, port) of the Foxglove live view (``--live``); None: no live view."""
    end_at_handover: bool = False
    """End the run when the exploration lap is over (at the RES go): stop reason 'handover'."""
    artifacts: bool = True
    """Write the run log, the plots and ``report.html`` (False: only ``summary.json``, for a
    campaign's runs, whose folders are not kept; the plots take about a second a run)."""


def default_out_dir(root: Path = Path("runs")) -> Path:
    """``runs/<date-time>/`` (local time, to the second; a suffix keeps it unique)."""
    stamp = dt.datetime.now().strftime("%Y-%m-%d_%H-%M-%S")
    out = root / stamp
    n = 1
    while out.exists():
        n += 1
        out = root / f"{stamp}_{n}"
    return out


def run_sim(config: AppConfig, options: SimOptions) -> dict[str, Any]:
    """Run one closed-loop simulation; write the run folder; return the summary."""
    if options.track is not None:
        config.sim.track = options.track
    apply_mission(config.mission, options.laps, options.mission, options.exploration)
    if options.seed is not None:
        config.sim.seed = options.seed
    if options.mapper is not None:
        config.mapper.backend = options.mapper  # type: ignore[assignment]
    if options.render is not None:
        config.run.render = options.render
    if options.record is not None:
        config.run.record = options.record

    out_dir = options.out_dir or default_out_dir()
    out_dir.mkdir(parents=True, exist_ok=True)
    track = load_track(config.sim.track)
    track.check_drivable(config.car.width_m)
    faults = [parse_fault(text) for text in options.faults]
    world = SimWorld(config, track, config.sim.seed, faults=faults,
                     mission=Mission[config.mission.mission.upper()])
    driver = ScriptedDriver(track, config.car, config.sim.seed,
                            speed_mps=config.sim.driver_speed_mps,
                            steer_noise_rad=config.sim.driver_steer_noise_rad)

    hasher = HashSink()
    recorder = None
    outputs: list[Any] = [hasher]
    if config.run.record:
        # The run's configuration goes with the recording, so that a replay runs the same stack.
        metadata = {"track": track.name, "seed": str(config.sim.seed),
                    "config_toml": config_to_toml(config)}
        recorder = _make_recorder(out_dir / "recording.mcap", config, metadata,
                                  options.realtime)
        outputs.append(recorder)
    try:
        live = start_live(options.live, config)
    except Exception:
        if recorder is not None:  # a port in use leaves nothing half-made
            recorder.close()
            recorder.path.unlink(missing_ok=True)
        raise
    if recorder is not None:
        recorder.write(TRUTH_TRACK, track, 0.0)
    if live is not None:
        live.write(TRUTH_TRACK, track, 0.0)
    clock = SimClock()
    sensors = make_sensors(config, clock)
    visualiser = None
    if config.run.render:
        from visualiser.visualiser import Visualiser

        visualiser = Visualiser(config.visualiser, out_dir / "frames", laps=config.mission.laps,
                                movie_path=_streamed_movie(config, out_dir))
    main = Main(
        config,
        sensors=sensors,
        mapper=make_mapper(config),
        planner=make_planner(config),
        controller=make_controller(config),
        outputs=outputs,
        recorder=recorder,
        visualiser=visualiser,
        live=live,
    )
    main.track = track

    runner = _SimRunner(config, options, track, world, driver, main, clock, recorder)
    try:
        result = runner.run()
    except BaseException:
        _close_outputs(live, sensors, recorder, visualiser)
        raise
    # the recorder's and the renderer's processes finish their files (and the streamed
    # movie) while this one draws the plots
    closer = _Closer(live, sensors, recorder, visualiser)
    return _finish(config, options, out_dir, track, world, main, runner, result, hasher,
                   visualiser, live, recorder, closer)


def _close_outputs(live: Any, sensors: Any, recorder: Any, visualiser: Any) -> None:
    """Stop the live view and the sensors, let the recorder and the renderer finish."""
    if live is not None:
        live.close()
    sensors.stop()
    if recorder is not None:
        progress_log.info("sim: closing the recording")
        recorder.close()
    if visualiser is not None:
        progress_log.info("sim: drawing the last frames")
        visualiser.close()


class _Closer(threading.Thread):
    """:func:`_close_outputs` in a thread (it waits on other processes); :meth:`finish` joins
    it and raises what it raised."""

    def __init__(self, *outputs: Any) -> None:
        super().__init__(name="sim-close")
        self._outputs = outputs
        self._error: BaseException | None = None
        self.start()

    def run(self) -> None:
        try:
            _close_outputs(*self._outputs)
        except BaseException as exc:  # noqa: BLE001 (raised again in the run's thread)
            self._error = exc

    def finish(self) -> None:
        self.join()
        if self._error is not None:
            raise self._error


def _finish(config: AppConfig, options: SimOptions, out_dir: Path, track: Track,
            world: SimWorld, main: Main, runner: _SimRunner, result: _Result,
            hasher: HashSink, visualiser: Any, live: Any, recorder: Any,
            closer: _Closer) -> dict[str, Any]:
    """The plots (while ``closer`` closes the outputs), the run's summary, ``summary.json``,
    the movie when it was not streamed, and the report."""
    plot_error: Exception | None = None
    try:
        if options.artifacts:
            runner.log.save(out_dir / "run_log.npz")
            progress_log.info("sim: writing the plots and report.html")
            try:
                _plots(out_dir, runner, track)
            except Exception as exc:  # raised once summary.json is written
                plot_error = exc
    finally:
        closer.finish()
    movie: threading.Thread | None = None
    if visualiser is not None and not (out_dir / config.visualiser.movie).is_file():
        # not streamed while the frames were drawn (a GIF, or the stream failed): made from
        # the PNG frames beside the summary (its PNG decoding and the pipe to ffmpeg, which
        # encodes in its own process, release the interpreter lock)
        progress_log.info("sim: making %s", config.visualiser.movie or "no movie")
        movie = threading.Thread(target=_movie, args=(config, out_dir), name="sim-movie")
        movie.start()
    try:
        summary = sim_summary(config, track, world, main, runner, result, hasher.hexdigest())
        if visualiser is not None:
            summary["frames"] = {"rendered": visualiser.submitted,
                                 "dropped": visualiser.dropped}
        if live is not None:
            summary["live"] = live.stats()
        if recorder is not None:
            summary["recording"] = {"written": recorder.written, "dropped": recorder.dropped,
                                    "errors": recorder.errors}
        (out_dir / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    finally:
        if movie is not None:
            movie.join()
    if plot_error is not None:
        raise plot_error
    if options.artifacts:
        _report(out_dir, summary)
    summary["out_dir"] = str(out_dir)
    return summary


def _make_recorder(path: Path, config: AppConfig, metadata: dict[str, str],
                   realtime: bool) -> Any:
    """The run's recorder of ``path``: a process of its own, as on the car
    (:mod:`orchestrator.live_recorder`), forked before any thread starts, so the loop pays only
    the hand-over of its messages and a killed run still leaves a complete recording. In real
    time it never blocks the loop (what does not fit is dropped and counted, as on the car);
    otherwise the loop waits for room, so that nothing is dropped."""
    recorder = RecorderProcess(path, config.recording, recorder_niceness(os.nice(0)),
                               log_level=logging.getLogger().getEffectiveLevel(),
                               car=config.car, metadata=metadata, start_method="fork",
                               blocking=not realtime)
    error = recorder.wait_started()
    if error is not None:
        recorder.close()
        raise RecordingError(error)
    return recorder


def _freeze_heap() -> None:
    """Collect once and freeze what the run built before its loop (track, managers, tables:
    it lives to the end), so that the collector's full passes during the loop skip it, as
    ``drive``'s processes do (:mod:`orchestrator.live`)."""
    gc.collect()
    gc.freeze()


@dataclass
class _Result:
    finished: bool
    stop_reason: str
    wall_time_s: float
    sim_time_s: float


class _SimRunner:
    """Steps the world and Main tick by tick and plays the person at the side of the track."""

    def __init__(self, config: AppConfig, options: SimOptions, track: Track, world: SimWorld,
                 driver: ScriptedDriver, main: Main, clock: SimClock, recorder: Any) -> None:
        self.config = config
        self.options = options
        self.track = track
        self.world = world
        self.driver = driver
        self.main = main
        self.clock = clock
        self.recorder = recorder
        self.log = RunLog()
        self.person = Handover(track, driver, world, overrun_m=config.run.exploration_overrun_m,
                               standstill_s=config.run.handover_standstill_s,
                               autonomous_exploration=config.mission.exploration == "autonomous",
                               ready_wait_s=config.controller.as_state.min_ready_s,
                               move_delay_s=config.controller.as_state.min_driving_before_move_s)
        self.loop_closure_time_s = math.nan
        self.timer = mission_timer(config.mission.mission, track, config.car)
        """Times acceleration and skidpad on their lines (ground truth); None otherwise."""
        self.estop: dict[str, float] | None = None
        self._estop_start: tuple[float, float, float, float] | None = None
        self._estop_path_m = 0.0
        self._last_xy = (0.0, 0.0)

    def run(self) -> _Result:
        config = self.config
        dt_s = 1.0 / config.run.control_rate_hz
        max_ticks = int(config.run.max_sim_time_s / dt_s)
        wall0 = time.perf_counter()
        pacer = RealClock() if self.options.realtime else None
        command: ActuatorCommand | None = None
        stop_reason = "timeout"
        finished = False
        progress = _Progress(self.options.progress, config.mission.laps)
        times = self.main.times
        perf = time.perf_counter
        _freeze_heap()
        for k in range(1, max_ticks + 1):
            t_s = k * dt_s
            if pacer is not None:
                pacer.sleep_until(t_s)
            t0 = perf()
            applied = self.person.command(t_s, self.world.truth(), command)
            raw = self.world.step_to(t_s, applied)
            self.clock.set(t_s)
            truth = self.world.truth()
            self.main.truth = truth
            t1 = perf()
            command = self.main.tick(t_s, raw)
            t2 = perf()
            if self.main.status_frame is not None:
                self.world.receive_can((self.main.status_frame,))
            t3 = perf()
            if k % 10 == 0:
                self._write_truth(t_s, truth)
            t4 = perf()
            self._observe(t_s, truth, command)
            laps_done = self.person.lap_times_s()
            progress.update(t_s, len(laps_done), self.person.phase,
                            laps_done[-1] if laps_done else None)
            done, reason, ok = self._done(t_s, truth)
            t5 = perf()
            times.add("simulator", t1 - t0 + t3 - t2)
            times.add("truth_out", t4 - t3)
            times.add("run", t5 - t4)
            if done:
                stop_reason, finished = reason, ok
                break
        progress.close()
        gc.unfreeze()
        return _Result(finished, stop_reason, time.perf_counter() - wall0, self.clock.now_s())

    def _write_truth(self, t_s: float, truth: Any) -> None:
        """The true pose and the estimate's error against it, to the recording and live view."""
        sinks = [s for s in (self.recorder, self.main.live) if s is not None]
        if not sinks:
            return
        error = None
        ms = self.main.map_state
        if ms is not None:
            dx, dy = ms.pose.x_m - truth.x_m, ms.pose.y_m - truth.y_m
            error = fsd_pb2.PoseError(timestamp_s=t_s, position_m=math.hypot(dx, dy), x_m=dx,
                                      y_m=dy, heading_rad=wrap_angle(ms.pose.yaw_rad
                                                                     - truth.yaw_rad))
        for sink in sinks:
            sink.write(TRUTH_POSE, truth, t_s)
            if error is not None:
                sink.write_proto(EVAL_POSE_ERROR, error, t_s)

    def _observe(self, t_s: float, truth: Any, command: ActuatorCommand) -> None:
        main = self.main
        self.person.observe(t_s, truth)
        if self.timer is not None:
            self.timer.observe(truth)
        speed = math.hypot(truth.vx_mps, truth.vy_mps)
        ms = main.map_state
        if ms is not None:
            if ms.loop_closed and math.isnan(self.loop_closure_time_s):
                self.loop_closure_time_s = t_s
            plan = main.plan
            target = plan.target_speed_mps if plan is not None else 0.0
            self.log.add(t_s, truth, ms.pose, target, command.throttle, command.brake,
                         command.steering_rad, ms.map_frozen)
        self._track_estop(t_s, truth, speed)

    def _track_estop(self, t_s: float, truth: Any, speed: float) -> None:
        if self.world.estop_active and self._estop_start is None:
            self._estop_start = (t_s, speed, truth.x_m, truth.y_m)
            self._last_xy = (truth.x_m, truth.y_m)
        if self._estop_start is not None and self.estop is None:
            self._estop_path_m += math.hypot(truth.x_m - self._last_xy[0],
                                             truth.y_m - self._last_xy[1])
            self._last_xy = (truth.x_m, truth.y_m)
            if speed < 0.05:
                t0, v0, _, _ = self._estop_start
                self.estop = {
                    "time_s": round(t0, 3),
                    "speed_mps": round(v0, 3),
                    "stop_distance_m": round(self._estop_path_m, 3),
                    "stop_time_s": round(t_s - t0, 3),
                    "allowed_distance_m": round(v0 * v0 / (2 * 10.0) + 0.1 * v0, 3),
                }

    def _done(self, t_s: float, truth: Any) -> tuple[bool, str, bool]:
        if self.options.end_at_handover and self.person.phase == Phase.AUTONOMOUS:
            return True, "handover", True
        controller = self.main.controller
        speed = math.hypot(truth.vx_mps, truth.vy_mps)
        state = controller.state
        if self.person.phase == Phase.AUTONOMOUS and state in (AsState.FINISHED, AsState.EMERGENCY):
            if speed < 0.05:
                reason = controller.stop_reason or state.name.lower()
                if self.estop is None and self._estop_start is not None:
                    return False, "", False
                return True, reason, state == AsState.FINISHED
        if self.world.estop_active and self.person.phase != Phase.AUTONOMOUS and speed < 0.05:
            return True, "estop", False
        waiting = self.person.waiting_since_s
        if (self.person.phase != Phase.AUTONOMOUS and math.isfinite(waiting)
                and t_s - waiting > self.config.run.ready_timeout_s
                and self.world.as_state_for_s(t_s, AsState.READY) == 0.0):
            machine = controller.as_machine
            why = "; ".join(machine.blockers) or machine.reason or "no AS_STATUS"
            reason = f"AS stayed {machine.state.name}: {why}"
            log.error("the car never showed READY: %s", reason)
            return True, reason, False
        return False, "", False


class _Progress:
    """Progress of a sim run (:class:`orchestrator.progress.Progress`): laps done of N, the
    simulated time, the real-time factor, the phase and the last lap time; a bar on a terminal
    (``bar``), else a plain line every :data:`PROGRESS_LINE_S` of wall time."""

    def __init__(self, bar: bool, laps: int) -> None:
        self.total = laps
        self._progress = Progress("sim", laps, "laps", bar, PROGRESS_LINE_S)

    def update(self, t_s: float, laps: int, phase: str, last_lap_s: float | None = None) -> None:
        def status() -> str:
            last = f", last lap {last_lap_s:.2f} s" if last_lap_s else ""
            return f"{realtime_status(t_s, self._progress.wall_s)}, {phase}{last}"

        self._progress.update(laps, status)

    def close(self) -> None:
        self._progress.close()


def _streamed_movie(config: AppConfig, out_dir: Path) -> Path | None:
    """The movie the renderer streams its frames into as it draws them (None: no movie, or
    one made from the PNG frames at the end)."""
    from visualiser.movie import STREAM_SUFFIXES

    name = config.visualiser.movie
    if not name or Path(name).suffix.lower() not in STREAM_SUFFIXES:
        return None
    return out_dir / name


def _movie(config: AppConfig, out_dir: Path) -> None:
    """The run's frames as a movie (``visualiser.movie``), when there are frames."""
    from visualiser.movie import frames_in, make_movie

    name = config.visualiser.movie
    frames = frames_in(out_dir / "frames")
    if not name or not frames:
        return
    try:
        make_movie(frames, out_dir / name, config.visualiser.movie_fps)
    except Exception:  # a movie is a convenience: the run's results stand without it
        log.exception("could not make %s", name)


def _report(out_dir: Path, summary: dict[str, Any]) -> None:
    """``report.html`` (a convenience: the run's results stand without it)."""
    from orchestrator.report import write_report

    try:
        write_report(out_dir, summary, title="sim")
    except Exception:
        log.exception("could not write report.html")


def _plots(out_dir: Path, runner: _SimRunner, track: Track) -> None:
    from visualiser.plots import write_summary_plots

    write_summary_plots(out_dir, runner.log.arrays(), track)
