"""--mission / --exploration reach sim, drive and emulate alike; the emulated car hands its
mission to ``drive`` in the config it writes."""

from __future__ import annotations

import tomllib
from pathlib import Path

import pytest

from main import build_parser
from orchestrator.config import AppConfig, MissionConfig, apply_mission


def test_autocross_is_one_lap_explored_by_the_stack() -> None:
    mission = MissionConfig(laps=10, mission="trackdrive", exploration="manual")
    apply_mission(mission, None, "autocross", "manual")
    assert (mission.mission, mission.exploration, mission.laps) == ("autocross", "autonomous", 1)


def test_nothing_given_keeps_the_config() -> None:
    mission = MissionConfig(laps=4, mission="trackdrive", exploration="autonomous")
    apply_mission(mission)
    assert (mission.mission, mission.exploration, mission.laps) == ("trackdrive", "autonomous", 4)


@pytest.mark.parametrize("command", ["sim", "drive", "emulate"])
def test_every_driving_command_takes_the_mission(command: str) -> None:
    args = build_parser().parse_args([command, "--mission", "autocross",
                                      "--exploration", "autonomous"])
    assert (args.mission, args.exploration) == ("autocross", "autonomous")
    with pytest.raises(SystemExit):
        build_parser().parse_args([command, "--mission", "skid"])


def test_emulated_car_writes_its_mission_for_drive(tmp_path: Path) -> None:
    from simulator.emulator import EmulatorOptions, HardwareEmulator

    emulator = HardwareEmulator(AppConfig(), EmulatorOptions(
        track="default", exploration_overrun_m=5.0, handover_standstill_s=1.0,
        workdir=tmp_path, mission="autocross", exploration="autonomous"))
    try:
        assert emulator.person.autonomous_exploration
        emulator.write_drive_config(tmp_path / "car.toml")
    finally:
        emulator.close()
    written = tomllib.loads((tmp_path / "car.toml").read_text())
    assert written["mission"] == {"mission": "autocross", "exploration": "autonomous"}


@pytest.mark.parametrize("name", ["acceleration", "skidpad"])
def test_acceleration_and_skidpad_are_one_run_with_nobody_driving(name: str) -> None:
    from orchestrator.config import MISSIONS, validate

    assert name in MISSIONS
    config = AppConfig()
    config.mission.exploration = "manual"
    config.mission.laps = 10
    apply_mission(config.mission, None, name, None)
    assert (config.mission.mission, config.mission.exploration, config.mission.laps) == (
        name, "autonomous", 1)
    validate(config)


@pytest.mark.parametrize("command", ["sim", "drive", "emulate"])
@pytest.mark.parametrize("name", ["acceleration", "skidpad"])
def test_every_driving_command_takes_acceleration_and_skidpad(command: str, name: str) -> None:
    args = build_parser().parse_args([command, "--mission", name])
    assert args.mission == name


def test_the_planner_drives_acceleration_and_skidpad_on_a_known_path() -> None:
    from orchestrator.managers import make_planner

    for name in ("acceleration", "skidpad"):
        config = AppConfig()
        apply_mission(config.mission, None, name, None)
        planner = make_planner(config)
        assert planner.known is not None and planner.known.mission == name
    assert make_planner(AppConfig()).known is None
