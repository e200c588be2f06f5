"""The application's configuration, assembled by Main from the packages' sections.

Each package declares its own section in its ``config.py``; Main owns two more: ``run`` (how it
schedules the layers, when a run ends) and ``mission`` (what the car is asked to do, handed to
the managers that need it). :func:`load_config` applies TOML override files onto the defaults
(``common.config``) and checks what a type alone cannot.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

from common.car import CarConfig
from common.config import load_overrides
from common.errors import ConfigError
from controller.config import ControllerConfig
from mapper.config import MapperConfig
from planner.config import PlannerConfig
from recordings.config import RecordingConfig
from sensors.config import SensorsConfig
from simulator.config import SimConfig
from visualiser.config import VisualiserConfig


@dataclass(slots=True)
class RunConfig:
    """How Main schedules the three layers (seed 002, 2.1.1) and when a run ends."""

    control_rate_hz: float = 100.0
    """Reactive layer: control and safety, every tick."""
    plan_rate_hz: float = 10.0
    """Deliberative layer: the path planner."""
    output_record_rate_hz: float = 10.0
    """How often the map state is recorded (and hashed); plans and commands are recorded as made."""
    max_sim_time_s: float = 900.0
    """A simulation that has not finished by then stops (reason 'timeout')."""
    handover_standstill_s: float = 1.0
    """After the exploration lap the car stands this long before the remote 'go'."""
    exploration_overrun_m: float = 12.0
    """The scripted exploration lap drives this far past the start line before stopping."""
    ready_timeout_s: float = 30.0
    """A simulation whose car has not shown READY (``AS_STATUS``) this long (s) after the person
    was ready to press go ends, with the AS machine's reason (a missing or unknown mission)."""
    render: bool = True
    """Render PNG frames (and a movie) of the run."""
    record: bool = True
    """Record raw sensor data and outputs to OUT/recording.mcap."""
    stale_input_s: float = 0.5
    """Readings older than this when they reach Main are rejected (counted)."""


@dataclass(slots=True)
class MissionConfig:
    """What the car is asked to do, and what is known of its start: Main hands these to the
    managers that need them (the Controller its laps, the Mapper the start heading)."""

    laps: int = 10
    """Laps before the car stops: with autonomous exploration every lap counts, the exploring
    one included (FSD trackdrive: 10); with manual exploration the autonomous laps after it."""
    mission: str = "trackdrive"
    """``trackdrive`` (laps of a track it maps on the first), ``autocross`` (one lap of an
    unseen track, explored as it goes), ``acceleration`` (the 75 m straight from standstill,
    then a stop in the run-off) or ``skidpad`` (two laps of the right circle, two of the left,
    then a stop in the exit lane); the last two on a path known from the rules' geometry."""
    exploration: str = "autonomous"
    """Who drives the first lap of trackdrive: ``autonomous`` (the stack, from the cones it
    sees, as at a Formula Student Driverless event) or ``manual`` (a person, seed 002's
    method; in simulation the scripted driver)."""
    start_heading_enu_rad: float | None = None
    """The world frame's heading in ENU (rad, counter-clockwise from east) when it is known (a
    dual antenna, a magnetometer, a surveyed start); None: the Mapper estimates it from GNSS."""


def apply_mission(mission: MissionConfig, laps: int | None = None, name: str | None = None,
                  exploration: str | None = None) -> None:
    """The command line's ``--laps``, ``--mission`` and ``--exploration`` over the config's
    mission (None: keep the config's). An autocross is one lap, explored by the stack;
    acceleration and skidpad are one run each (their "lap" ends with the car stopped past the
    finish), with nobody driving before the stack either."""
    if laps is not None:
        mission.laps = laps
    if name is not None:
        mission.mission = name
    if exploration is not None:
        mission.exploration = exploration
    if mission.mission in ("autocross", "acceleration", "skidpad"):
        mission.exploration = "autonomous"
        mission.laps = 1


@dataclass(slots=True)
class AppConfig:
    """Everything configurable, one section per manager, plus the car, the run and the mission."""

    car: CarConfig = field(default_factory=CarConfig)
    sensors: SensorsConfig = field(default_factory=SensorsConfig)
    mapper: MapperConfig = field(default_factory=MapperConfig)
    planner: PlannerConfig = field(default_factory=PlannerConfig)
    controller: ControllerConfig = field(default_factory=ControllerConfig)
    sim: SimConfig = field(default_factory=SimConfig)
    visualiser: VisualiserConfig = field(default_factory=VisualiserConfig)
    recording: RecordingConfig = field(default_factory=RecordingConfig)
    run: RunConfig = field(default_factory=RunConfig)
    mission: MissionConfig = field(default_factory=MissionConfig)


def load_config(*paths: str | Path | None) -> AppConfig:
    """The defaults, overridden by each given TOML file in turn (``None`` entries are skipped)."""
    config = load_overrides(AppConfig(), *paths)
    validate(config)
    return config


MISSIONS = ("trackdrive", "autocross", "acceleration", "skidpad")
"""The missions ``sim``, ``emulate`` and ``drive`` drive (``mission.mission``)."""
EXPLORATIONS = ("autonomous", "manual")


def validate(config: AppConfig) -> None:
    """Cross-field sanity checks that a type alone cannot express."""
    mission = config.mission
    if mission.mission not in MISSIONS:
        raise ConfigError(f"config: 'mission.mission' must be one of {', '.join(MISSIONS)}, "
                          f"got {mission.mission!r}")
    if mission.exploration not in EXPLORATIONS:
        raise ConfigError(f"config: 'mission.exploration' must be one of "
                          f"{', '.join(EXPLORATIONS)}, got {mission.exploration!r}")
    if mission.laps < 1:
        raise ConfigError(f"config: 'mission.laps' must be >= 1, got {mission.laps!r}")
    car = config.car
    for name in ("wheelbase_m", "length_m", "width_m", "max_lateral_accel_mps2",
                 "max_drive_accel_mps2", "max_brake_decel_mps2", "max_steer_rad", "top_speed_mps"):
        value = getattr(car, name)
        if not (math.isfinite(value) and value > 0.0):
            raise ConfigError(f"config: 'car.{name}' must be a positive number, got {value!r}")
    planner = config.planner
    for name in ("lateral_safety_factor", "exploration_lateral_safety_factor"):
        value = getattr(planner, name)
        if not (math.isfinite(value) and 0.0 < value <= 1.0):
            raise ConfigError(f"config: 'planner.{name}' must be in (0, 1], got {value!r}")
    if not planner.exploration_tight_room_m < planner.exploration_wide_room_m:
        raise ConfigError("config: 'planner.exploration_tight_room_m' must be below "
                          "'planner.exploration_wide_room_m', got "
                          f"{planner.exploration_tight_room_m!r} and "
                          f"{planner.exploration_wide_room_m!r}")
