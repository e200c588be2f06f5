"""``tune`` (issue 18.2): the space file is checked, a trial is scored on its runs with the
0-cones constraint, the best setting is written as a TOML override that ``--config`` takes, and
a short study on Ray runs the configuration as it is first."""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import pytest

import main
from common.errors import ConfigError
from orchestrator.config import AppConfig, load_config
from scale.tune import current_value, load_space, score, write_override
from support.shared_data import shared_data

ROOT = Path(main.__file__).parent
EXAMPLE_SPACE = ROOT / "scale" / "tune_space.toml"


def test_example_space_loads_and_contains_the_defaults() -> None:
    config = AppConfig()
    params = load_space(EXAMPLE_SPACE, config)
    keys = {p.key for p in params}
    assert {"planner.lateral_safety_factor", "controller.lookahead_time_s"} <= keys
    assert any(k.startswith("mapper.") for k in keys)  # a filter parameter
    for p in params:
        assert p.low is not None and p.high is not None
        assert p.low <= current_value(config, p.key) <= p.high


@pytest.mark.parametrize("text, words", [
    ('[params."planner.nope"]\nlow = 0.1\nhigh = 0.2\n', "nope"),
    ('[params."planner.lateral_safety_factor"]\nlow = 0.9\nhigh = 0.2\n', "low < high"),
    ('[params."planner.lateral_safety_factor"]\nlow = 0\nhigh = 1\nlog = true\n', "log"),
    ('[params."planner.lateral_safety_factor"]\nlo = 0.1\nhigh = 0.2\n', "unknown field"),
    ("x = 1\n", "params"),
])
def test_bad_space_is_one_line_error(tmp_path: Path, text: str, words: str) -> None:
    path = tmp_path / "space.toml"
    path.write_text(text)
    with pytest.raises(ConfigError, match=words) as info:
        load_space(path, AppConfig())
    assert "\n" not in str(info.value) and str(path) in str(info.value)


def _row(lap: str, cones: int = 0, error: str = "", finished: str = "True") -> dict[str, str]:
    return {"best_lap_time_s": lap, "cones_hit": str(cones), "off_track": "0", "error": error,
            "finished": finished}


def test_score_mean_best_lap_and_constraint() -> None:
    clean = score(1, {}, [_row("10.0"), _row("12.0")], limit_s=300.0)
    assert clean.value == pytest.approx(11.0) and clean.feasible
    hit = score(2, {}, [_row("9.0", cones=2), _row("10.0")], limit_s=300.0)
    assert hit.value < clean.value and not hit.feasible  # faster but hits cones: infeasible
    failed = score(3, {}, [_row("", error="TrackError: x", finished=""), _row("10.0")], 300.0)
    assert failed.value == pytest.approx((300.0 + 10.0) / 2) and not failed.feasible
    assert math.isfinite(failed.value)


def test_best_setting_is_a_config_override(tmp_path: Path) -> None:
    base = tmp_path / "base.toml"
    base.write_text("[mission]\nlaps = 3\n")
    best = tmp_path / "best.toml"
    write_override(best, {"planner.lateral_safety_factor": 0.7,
                          "mapper.slam.gyro_noise_density_radps_rthz": 2.0e-4}, base)
    config = load_config(best)
    assert config.planner.lateral_safety_factor == 0.7
    assert config.mapper.slam.gyro_noise_density_radps_rthz == 2.0e-4
    assert config.mission.laps == 3  # the tuned --config's overrides are kept


@pytest.mark.slow
def test_short_study_on_ray(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    oval = shared_data("tracks", "eufs", "small_oval.csv")
    space = tmp_path / "space.toml"
    space.write_text('[params."planner.lateral_safety_factor"]\nlow = 0.55\nhigh = 0.75\n')
    out = tmp_path / "tune"
    code = main.cli(["tune", "--space", str(space), "--trials", "2", "--batch", "2",
                     "--tracks", str(oval), "--seeds", "3", "--laps", "1", "--cpus", "2",
                     "--out", str(out), "--no-progress"])
    with (out / "trials.csv").open(newline="") as fh:
        trials = list(csv.DictReader(fh))
    assert [int(t["trial"]) for t in trials] == [0, 1]
    assert json.loads(trials[0]["params"]) == {"planner.lateral_safety_factor": 0.6}  # as is
    summary = json.loads((out / "tune.json").read_text())
    assert summary["baseline"]["trial"] == 0 and summary["trials"] == 2
    assert summary["baseline"]["mean_best_lap_s"] == pytest.approx(float(trials[0]["value_s"]))
    # the configuration as it is drives small_oval seed 3 clean: there is a best trial
    assert code == 0 and summary["best"]["feasible"] and summary["best"]["cones_hit"] == 0
    assert summary["best"]["mean_best_lap_s"] <= summary["baseline"]["mean_best_lap_s"]
    best = load_config(out / "best.toml")
    assert best.planner.lateral_safety_factor == summary["best"]["params"][
        "planner.lateral_safety_factor"]
    assert "improvement_s=" in capsys.readouterr().out
