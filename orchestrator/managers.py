"""Main builds the managers: each gets its own section of the configuration, the car's, and what
of the mission it needs (the Controller its laps, the Mapper a known start heading)."""

from __future__ import annotations

from typing import Any

from common.clock import Clock
from controller.as_state_machine import AsStateMachine
from controller.controller import Controller
from controller.safety import late_stop_distance_m
from mapper.mapper import Mapper
from orchestrator.config import AppConfig
from planner.path_planner import PathPlanner
from sensors.config import SensorsConfig
from sensors.manager import SensorManager


def make_sensors(config: AppConfig, clock: Clock, sensors: SensorsConfig | None = None,
                 **options: Any) -> SensorManager:
    """The Sensor Manager on ``clock``; ``sensors`` replaces the configuration's section (a
    process that runs only some sources); ``options`` go to :class:`SensorManager`."""
    return SensorManager(sensors if sensors is not None else config.sensors, config.car, clock,
                         **options)


def make_mapper(config: AppConfig) -> Mapper:
    """The Mapper, told the start heading when the mission knows it."""
    return Mapper(config.mapper, config.car, config.mission.start_heading_enu_rad)


def make_planner(config: AppConfig) -> PathPlanner:
    """The Path Planner, for the mission's path (known in advance or not), told the room the
    safety supervisor wants a late plan to leave for a stop."""
    safety = config.controller.safety
    return PathPlanner(config.planner, config.car, config.mission.mission,
                       stop_distance_m=lambda speed_mps: late_stop_distance_m(speed_mps, safety))


def make_controller(config: AppConfig) -> Controller:
    """The Controller, with the mission's laps and THE AS state machine (the rules' timings,
    ``[controller.as_state]``): its mission comes from ``MISSION_SELECT``, handed in by Main."""
    machine = AsStateMachine(config.controller.as_state)
    return Controller(config.controller, config.car, config.mission.laps, as_machine=machine)
