"""The FSD AS state machine wired into Main and the simulated car (issue 15).

The simulated car selects the run's mission in ``MISSION_SELECT``; the stack decodes it and Main
hands it to the ONE AS state machine the controller's state comes from; the stack reports
``AS_STATUS`` (10 Hz and on every change) and the car decodes it (the person presses go once
the ASSI has shown READY for the rules' 5 s; the car moves 3 s after the go). Checked through
whole sim runs on the built-in track: the transitions and their times, an unknown or missing
mission (stays OFF, one log line, the run ends with the reason), the e-stop (EMERGENCY, a safe
stop)."""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from common.messages import Mission, MissionSelect
from orchestrator.config import AppConfig
from orchestrator.sim import SimOptions, run_sim
from sensors.can_codec import CanCodec
from simulator.tracks import load_track
from simulator.world import SimWorld

RULES_READY_S = 5.0
RULES_MOVE_S = 3.0


def autocross(tmp_path: Path, config: AppConfig | None = None,
              faults: list[str] | None = None) -> dict[str, Any]:
    return run_sim(config or AppConfig(),
                   SimOptions(track="default", seed=3, mission="autocross", render=False,
                              record=False, out_dir=tmp_path, faults=faults or []))


def missions_sent(world: SimWorld, seconds: float) -> list[MissionSelect]:
    codec = CanCodec()
    raw = world.step_to(seconds)
    return [r for frame in raw if hasattr(frame, "arbitration_id")
            for r in codec.decode(frame) if isinstance(r, MissionSelect)]  # type: ignore[arg-type]


@pytest.mark.parametrize("setting, expected", [
    ("run", Mission.SKIDPAD), ("autocross", Mission.AUTOCROSS), ("12", Mission.UNKNOWN),
    ("missing", None)])
def test_the_simulated_car_sends_mission_select(setting: str, expected: Mission | None) -> None:
    config = AppConfig()
    config.sim.mission_select = setting
    world = SimWorld(config, load_track("default"), mission=Mission.SKIDPAD)
    sent = missions_sent(world, 1.0)
    if expected is None:
        assert sent == []
        return
    assert 9 <= len(sent) <= 11  # 10 Hz
    assert {m.mission for m in sent} == {expected}
    if setting == "12":
        assert {m.raw_value for m in sent} == {12}


@pytest.mark.slow
def test_a_sim_run_steps_the_as_machine_off_ready_driving_finished(tmp_path: Path) -> None:
    summary = autocross(tmp_path)
    assert summary["finished"], summary["stop_reason"]
    assert summary["as_state"] == "FINISHED"
    steps = [(t["from"], t["to"]) for t in summary["as_transitions"]]
    assert steps == [("OFF", "READY"), ("READY", "DRIVING"), ("DRIVING", "FINISHED")]
    ready_s, driving_s, finished_s = (t["time_s"] for t in summary["as_transitions"])
    assert ready_s < 1.0  # the first MISSION_SELECT frames, a pose, fresh sensors
    assert driving_s - ready_s >= RULES_READY_S  # T14.8.4: 5 s in READY before the go
    assert driving_s - ready_s < RULES_READY_S + 0.3  # the person pressed go once it was shown
    assert summary["as_transitions"][1]["reason"] == "RES go"
    # T14.8.5: the car stands for 3 s in DRIVING, then it moves
    log = np.load(tmp_path / "run_log.npz")
    moving = log["t_s"][log["truth"][:, 3] > 0.05]
    assert moving.size and driving_s + RULES_MOVE_S <= moving[0] < driving_s + RULES_MOVE_S + 1.0
    assert finished_s > driving_s + summary["lap_times_s"][0]
    # the car decoded AS_STATUS (10 Hz, and at once on a change): the same states, same times
    car = summary["as_status_car"]
    assert 10 * finished_s - 5 <= car["frames"] <= 10 * finished_s + 20
    assert [t["state"] for t in car["transitions"]] == ["OFF", "READY", "DRIVING", "FINISHED"]
    assert [t["time_s"] for t in car["transitions"][1:]] == [ready_s, driving_s, finished_s]
    assert car["state"] == "FINISHED" and car["assi"] == "BLUE_CONTINUOUS"
    assert car["mission"] == "AUTOCROSS" and car["lap"] == 1


@pytest.mark.parametrize("setting, reason", [
    ("9", "unknown mission"), ("unknown", "unknown mission"),
    ("missing", "no mission selected"), ("none", "no mission selected")])
def test_an_unknown_or_missing_mission_keeps_the_car_off(
        tmp_path: Path, caplog: pytest.LogCaptureFixture, setting: str, reason: str) -> None:
    caplog.set_level(logging.INFO)
    config = AppConfig()
    config.sim.mission_select = setting
    config.run.ready_timeout_s = 2.0
    summary = autocross(tmp_path, config)
    assert not summary["finished"]
    assert summary["stop_reason"].startswith(f"AS stayed OFF: {reason}"), summary["stop_reason"]
    assert summary["as_state"] == "OFF" and summary["as_transitions"] == []
    assert summary["as_status_car"]["state"] == "OFF"
    assert summary["as_status_car"]["assi"] == "OFF"
    assert summary["laps_completed"] == 0 and summary["handover_time_s"] is None
    lines = [r for r in caplog.records if r.name == "controller.as_state_machine"]
    assert len(lines) == 1 and reason in lines[0].getMessage()
    assert lines[0].levelno == logging.WARNING


def test_an_estop_while_driving_is_an_emergency_and_a_safe_stop(tmp_path: Path) -> None:
    summary = autocross(tmp_path, faults=["estop@12"])
    assert not summary["finished"]
    assert summary["stop_reason"] == "remote emergency stop"
    assert summary["as_state"] == "EMERGENCY"
    last = summary["as_transitions"][-1]
    assert (last["from"], last["to"]) == ("DRIVING", "EMERGENCY")
    assert 12.0 <= last["time_s"] <= 12.2
    assert summary["as_status_car"]["assi"] == "BLUE_FLASHING"
    estop = summary["estop"]
    assert estop["speed_mps"] > 1.0
    assert estop["stop_distance_m"] <= estop["allowed_distance_m"]
