"""Replay: a recording's raw sensor data fed through the same Main, tick by tick.

Main ticks at exactly the times it ticked when the recording was made (k / control_rate_hz), and
each tick is handed the raw units whose log time falls in it, so the map states, plans and
commands are the recording's own, bit for bit, whatever the replay rate: ``--rate R`` only paces
how fast the recording is read (on its own clock), never what is in a tick.

The stack is configured as in the run that made the recording (its configuration is stored in
the recording's ``fsd`` metadata as TOML), with the replay's own ``--config`` file on top: the
run's ``--laps`` or mapper choice is part of what it computed.
"""

from __future__ import annotations

import json
import logging
import math
import time
import tomllib
from collections.abc import Sequence
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np

from common.config import apply_overrides
from common.conventions import wrap_angles
from common.errors import ConfigError, RecordingError
from common.messages import CanFrame, Health, RawBytes
from mapper.evaluation import evaluate_map
from orchestrator.config import AppConfig
from orchestrator.main_loop import Main
from orchestrator.managers import make_controller, make_mapper, make_planner
from orchestrator.outputs import HashSink, start_live
from orchestrator.progress import Progress, realtime_status
from orchestrator.replay_front import (
    FrontEndTimes,
    TickInput,
    tick_inputs,
    tick_inputs_in_process,
)
from recordings.player import Player
from recordings.reader import RecordingReader
from recordings.topics import COMMAND, TRUTH_POSE, TRUTH_TRACK
from sensors.manager import SensorBatch

log = logging.getLogger(__name__)


@dataclass
class ReplayOptions:
    """``replay`` options: ``rate`` None is as fast as possible (``--max``)."""

    path: Path
    rate: float | None = None
    out_dir: Path | None = None
    render: bool = False
    config_file: Path | None = None
    """The replay's own ``--config`` file, applied on top of the recording's configuration."""
    use_recorded_config: bool = True
    pipeline: bool = True
    """Read and parse the recording in a process of its own, beside Main (same outputs)."""
    live: tuple[str, int] | None = None
    """(host, port) of the Foxglove live view (``--live``); None: no live view."""
    progress: bool = False
    """A progress bar (on a terminal); otherwise a plain progress line every few seconds."""


class TickSensors:
    """The Sensor Manager as Main sees it in a replay: each tick's readings and health come
    ready from the front end (:mod:`orchestrator.replay_front`)."""

    def __init__(self) -> None:
        self._tick: TickInput | None = None

    def hand(self, tick: TickInput) -> None:
        """The front end's output for the next tick."""
        self._tick = tick

    def ingest(self, raw: Sequence[RawBytes | CanFrame]) -> None:
        raise RecordingError("a replay's raw units are parsed by its front end, not by Main")

    def take(self) -> SensorBatch:
        assert self._tick is not None, "hand() a tick before Main.tick"
        return SensorBatch([], self._tick.readings, {})

    def health(self, now_s: float) -> Health:
        assert self._tick is not None and abs(self._tick.t_s - now_s) < 1e-9, \
            "health asked for another tick than the one handed"
        return self._tick.health

    def report_status(self, status: object) -> None:
        """A replay has no car to report ``AS_STATUS`` to: nothing is sent."""
        return None


def last_command_time_s(path: Path) -> float:
    """Log time (s) of the last actuator command in a recording: where its run stopped."""
    with RecordingReader(path) as reader:
        last_ns = reader.last_log_time_ns(COMMAND)
    return math.nan if last_ns is None else last_ns * 1e-9


def recorded_config(path: Path) -> dict[str, Any] | None:
    """The configuration of the run that made the recording (None: the recording has none)."""
    text = Player(path, rate=None).metadata.get("fsd", {}).get("config_toml")
    if not text:
        return None
    try:
        return upgrade_config(tomllib.loads(text))
    except tomllib.TOMLDecodeError as exc:
        log.warning("%s: unreadable recorded configuration (%s); using the given one", path, exc)
        return None


def upgrade_config(recorded: dict[str, Any]) -> dict[str, Any]:
    """A configuration recorded before the mission section existed, in today's keys (in place):
    ``sim.laps`` and ``controller.laps`` are ``mission.laps``; ``mapper.ukf.start_heading_known``
    became ``mission.start_heading_enu_rad`` (the simulated world's heading when it was true)."""
    sim = recorded.get("sim", {})
    mission = recorded.setdefault("mission", {})
    if "laps" in sim:
        mission.setdefault("laps", sim.pop("laps"))
    controller_laps = recorded.get("controller", {}).pop("laps", None)
    if controller_laps is not None:
        mission["laps"] = controller_laps
    if recorded.get("mapper", {}).get("ukf", {}).pop("start_heading_known", False):
        mission.setdefault("start_heading_enu_rad", sim.get("start_heading_enu_rad", 0.0))
    if not mission:
        del recorded["mission"]
    return recorded


def replay_config(config: AppConfig, path: Path, config_file: Path | None) -> AppConfig:
    """The recording's configuration with ``config_file`` on top; ``config`` if it has none."""
    recorded = recorded_config(path)
    if recorded is None:
        return config
    try:
        merged = apply_overrides(AppConfig(), recorded, f"{path} (recorded configuration)")
    except ConfigError as exc:
        log.warning("%s; replaying with the given configuration instead", exc)
        return config
    if config_file is not None:
        with config_file.open("rb") as fh:
            apply_overrides(merged, tomllib.load(fh), str(config_file))
    log.info("replaying with the recording's configuration%s",
             f" overridden by {config_file}" if config_file is not None else "")
    return merged


def _status(t_s: float, progress: Progress) -> str:
    return realtime_status(t_s, progress.wall_s)


def run_replay(config: AppConfig, options: ReplayOptions) -> dict[str, Any]:
    """Replay a recording through Main; write ``summary.json`` when an out dir is given."""
    path = options.path
    if not path.exists():
        raise RecordingError(f"{path}: no such recording")
    if options.use_recorded_config:
        config = replay_config(config, path, options.config_file)
    from orchestrator.localise import is_localisation_recording, run_localisation

    if is_localisation_recording(path):
        log.info("%s has no commands and no track: localisation only", path)
        return run_localisation(config, path, options.out_dir, options.rate)
    end_s = last_command_time_s(path)
    if not math.isfinite(end_s):
        raise RecordingError(f"{path}: has no /command messages to know where the run ended")
    dt_s = 1.0 / config.run.control_rate_hz
    n_ticks = int(round(end_s / dt_s))

    hasher = HashSink()
    sensors = TickSensors()
    front_times = FrontEndTimes()
    # The front end starts first: a forked process must not inherit the visualiser's.
    make_ticks = tick_inputs_in_process if options.pipeline else tick_inputs
    ticks = make_ticks(config, path, options.rate, n_ticks, front_times)
    visualiser = None
    if options.render and options.out_dir is not None:
        from visualiser.visualiser import Visualiser

        visualiser = Visualiser(config.visualiser, options.out_dir / "frames",
                                laps=config.mission.laps)
    try:
        live = start_live(options.live, config)
    except BaseException:
        getattr(ticks, "close", lambda: None)()
        raise
    main = Main(config, sensors=sensors, mapper=make_mapper(config),
                planner=make_planner(config), controller=make_controller(config),
                outputs=[hasher], visualiser=visualiser, live=live)

    truth_t: list[float] = []
    truth_pose: list[tuple[float, float, float]] = []
    est_pose: dict[float, tuple[float, float, float]] = {}
    track = None
    wall0 = time.perf_counter()
    progress = Progress("replay", round(n_ticks * dt_s), "s of recording", options.progress)
    try:
        for tick in ticks:
            for log_time_s, message in tick.truth:
                truth_t.append(log_time_s)
                truth_pose.append((message.x_m, message.y_m, message.yaw_rad))
                main.truth = message
                if live is not None:
                    live.write(TRUTH_POSE, message, log_time_s)
            if tick.track is not None:
                track = main.track = tick.track
                if live is not None:
                    live.write(TRUTH_TRACK, track, tick.t_s)
            sensors.hand(tick)
            main.tick(tick.t_s)
            if main.map_state is not None and truth_t and abs(truth_t[-1] - tick.t_s) < 1e-6:
                pose = main.map_state.pose
                est_pose[truth_t[-1]] = (pose.x_m, pose.y_m, pose.yaw_rad)
            progress.update(int(tick.t_s), partial(_status, tick.t_s, progress))
    finally:
        progress.close()
        close = getattr(ticks, "close", None)
        if close is not None:
            close()
        if live is not None:
            live.close()
    wall_s = time.perf_counter() - wall0
    if visualiser is not None:
        visualiser.close()

    summary: dict[str, Any] = {
        "recording": str(path),
        "rate": options.rate,
        "ticks": n_ticks,
        "outputs_sha256": hasher.hexdigest(),
        "timing": {
            "sim_time_s": round(n_ticks * dt_s, 3),
            "wall_time_s": round(wall_s, 3),
            "realtime_factor": round(n_ticks * dt_s / max(wall_s, 1e-9), 3),
            "stages_ms": main.times.summary_ms(),
            "front_end": {"pipelined": options.pipeline,
                          "read_s": round(front_times.read_s, 4),
                          "sensors_s": round(front_times.sensors_s, 4)},
        },
        # a driven run's replay does not estimate the GNSS latency (the localisation replay
        # of a recorded drive does: orchestrator/localise.py); unset, the Mapper uses 0
        "gnss_latency_s": config.mapper.ukf.gnss_latency_s or 0.0,
        "gnss_latency_source": ("configured" if config.mapper.ukf.gnss_latency_s is not None
                                else "unset"),
    }
    if truth_pose and est_pose:
        pairs = [(truth_pose[i], est_pose[t]) for i, t in enumerate(truth_t) if t in est_pose]
        truth_arr = np.asarray([p[0] for p in pairs])
        est_arr = np.asarray([p[1] for p in pairs])
        d = est_arr[:, :2] - truth_arr[:, :2]
        dyaw = wrap_angles(est_arr[:, 2] - truth_arr[:, 2])
        summary["pose_rmse_m"] = round(float(np.sqrt(np.mean(np.sum(d * d, axis=1)))), 4)
        summary["heading_rmse_rad"] = round(float(np.sqrt(np.mean(dyaw**2))), 5)
        summary["final_offset_m"] = round(float(np.hypot(*d[-1])), 4)
    if live is not None:
        summary["live"] = live.stats()
    if track is not None and main.map_state is not None:
        summary["map"] = evaluate_map(main.map_state.cones, track.cones_xy_m, track.colours)
    if options.out_dir is not None:
        options.out_dir.mkdir(parents=True, exist_ok=True)
        (options.out_dir / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
        from orchestrator.report import write_report

        write_report(options.out_dir, summary, title="replay")
    return summary
