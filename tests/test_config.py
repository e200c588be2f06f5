"""Configuration: defaults, overrides, and one-line errors naming the file and the key."""

from __future__ import annotations

import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

from common.config import apply_overrides, config_to_toml
from common.errors import ConfigError
from orchestrator.config import AppConfig, load_config

ROOT = Path(__file__).resolve().parent.parent


def write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "c.toml"
    path.write_text(text)
    return path


def test_defaults_are_the_default_car() -> None:
    config = load_config()
    assert config.car.wheelbase_m == 1.53
    assert config.car.max_brake_decel_mps2 == 12.0
    assert config.mapper.smoother.match_distance_m == 1.5


def test_override_applies(tmp_path: Path) -> None:
    config = load_config(write(tmp_path, "[car]\nwheelbase_m = 1.6\n[sensors.gps]\nport = 'x'\n"))
    assert config.car.wheelbase_m == 1.6
    assert config.sensors.gps.port == "x"
    assert config.car.track_width_m == 1.2  # untouched


def test_int_accepted_for_float(tmp_path: Path) -> None:
    assert load_config(write(tmp_path, "[car]\ntop_speed_mps = 20\n")).car.top_speed_mps == 20.0


@pytest.mark.parametrize(
    ("text", "fragments"),
    [
        ("[nosuch]\nx = 1\n", ["unknown section [nosuch]"]),
        ("[car]\nwheel_base = 1.0\n", ["unknown key 'car.wheel_base'"]),
        ("[car]\nwheelbase_m = 'long'\n", ["car.wheelbase_m", "float"]),
        ("[sensors.gps]\nbaudrate = 9600.5\n", ["sensors.gps.baudrate", "int"]),
        ("[sensors.gps]\nenabled = 1\n", ["sensors.gps.enabled", "bool"]),
        ("[mapper]\nbackend = 'fastslam'\n", ["mapper.backend", "'slam' or 'smoother'"]),
        ("car = 3\n", ["'car' is a section"]),
        ("[car\n", ["not valid TOML"]),
        ("[car]\nwheelbase_m = -1.0\n", ["car.wheelbase_m", "positive"]),
        ("[planner]\nexploration_lateral_safety_factor = 0.0\n",
         ["planner.exploration_lateral_safety_factor", "(0, 1]"]),
        ("[planner]\nlateral_safety_factor = 1.2\n", ["planner.lateral_safety_factor", "(0, 1]"]),
        ("[planner]\nexploration_tight_room_m = 1.5\n",
         ["planner.exploration_tight_room_m", "below", "exploration_wide_room_m"]),
    ],
)
def test_bad_config_one_line(tmp_path: Path, text: str, fragments: list[str]) -> None:
    path = write(tmp_path, text)
    with pytest.raises(ConfigError) as info:
        load_config(path)
    message = str(info.value)
    assert "\n" not in message
    for fragment in fragments:
        assert fragment in message


def test_missing_file_names_it(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="not found"):
        load_config(tmp_path / "absent.toml")


def test_print_round_trips(tmp_path: Path) -> None:
    text = config_to_toml(AppConfig())
    path = write(tmp_path, text)
    assert tomllib.loads(text)["car"]["wheelbase_m"] == 1.53
    assert config_to_toml(load_config(path)) == text


@pytest.mark.parametrize("name", sorted(p.name for p in (ROOT / "config").glob("*.toml")))
def test_shipped_configs_load(name: str) -> None:
    load_config(ROOT / "config" / name)


def test_cli_bad_config_exits_with_one_line(tmp_path: Path) -> None:
    path = write(tmp_path, "[nosuch]\nx = 1\n")
    result = subprocess.run(
        [sys.executable, "main.py", "config", "--print", "--config", str(path)],
        cwd=ROOT, capture_output=True, text=True, timeout=60,
    )
    assert result.returncode != 0
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    assert "nosuch" in lines[0] and str(path) in lines[0]
    assert "Traceback" not in result.stderr


def test_cli_config_print(tmp_path: Path) -> None:
    path = write(tmp_path, "[car]\nwheelbase_m = 1.7\n")
    result = subprocess.run(
        [sys.executable, "main.py", "config", "--print", "--config", str(path)],
        cwd=ROOT, capture_output=True, text=True, timeout=60,
    )
    assert result.returncode == 0, result.stderr
    assert tomllib.loads(result.stdout)["car"]["wheelbase_m"] == 1.7


@pytest.mark.parametrize(
    "command",
    [["sim"], ["replay", "x.mcap"], ["render", "x.mcap", "--out", "o"], ["info", "x.mcap"],
     ["drive"], ["record", "--out", "x.mcap"], ["emulate"], ["decode", "nmea", "x.log"]],
)
def test_every_subcommand_stops_on_a_bad_config(tmp_path: Path, command: list[str]) -> None:
    path = write(tmp_path, "[car]\nwheelbase = 1.5\n")
    result = subprocess.run(
        [sys.executable, "main.py", *command, "--config", str(path)],
        cwd=ROOT, capture_output=True, text=True, timeout=60,
    )
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "car.wheelbase" in lines[0] and str(path) in lines[0], lines


def test_recorded_configuration_of_before_the_mission_section_is_upgraded() -> None:
    from orchestrator.replay import upgrade_config

    old = {"sim": {"laps": 3, "start_heading_enu_rad": 0.7},
           "controller": {"rate_hz": 100.0},
           "mapper": {"ukf": {"start_heading_known": True}}}
    config = apply_overrides(AppConfig(), upgrade_config(old))
    assert config.mission.laps == 3
    assert config.mission.start_heading_enu_rad == 0.7
    assert config.sim.start_heading_enu_rad == 0.7
    unknown = apply_overrides(AppConfig(), upgrade_config({"sim": {"laps": 2}}))
    assert unknown.mission.laps == 2 and unknown.mission.start_heading_enu_rad is None
