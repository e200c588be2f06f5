"""Acceleration and skidpad driven by the stack alone in simulation, on the EUFS layouts: clean,
finished, and timed as the rules time them, no faster than the friction limit allows and not
much slower."""

from __future__ import annotations

import pytest

from support.shared_data import shared_path


def _run(mission: str, tmp_path, artifacts: bool = True) -> dict:  # type: ignore[no-untyped-def]
    from orchestrator.config import AppConfig
    from orchestrator.sim import SimOptions, run_sim

    track = str(shared_path("tracks", "eufs", f"{mission}.csv"))
    return run_sim(AppConfig(), SimOptions(track=track, seed=3, mission=mission, render=False,
                                           record=False, out_dir=tmp_path,
                                           artifacts=artifacts))


@pytest.mark.shared_data("tracks/eufs/acceleration.csv")
@pytest.mark.slow
def test_acceleration_from_standstill_down_the_straight_and_stopped_in_the_run_off(
        tmp_path) -> None:
    summary = _run("acceleration", tmp_path, artifacts=False)  # as a campaign runs it
    assert sorted(p.name for p in tmp_path.iterdir()) == ["summary.json"]
    assert summary["mission"] == "acceleration"
    assert summary["finished"], summary["stop_reason"]
    assert summary["cones_hit"] == 0
    assert summary["off_track"] == 0
    result = summary["mission_result"]
    assert result["distance_m"] == pytest.approx(75.0, abs=0.5)
    # the point mass at the friction limit is the bound; the car brakes before the finish to
    # stand in a 25 m run-off, and its controller lags the profile: within a quarter of it
    assert result["min_time_s"] <= result["time_s"] <= 1.2 * result["min_time_s"]
    # 75 m from (nearly) standstill at up to 8 m/s^2 and 25 m/s: 3.5 .. 6 s
    assert 3.5 < result["time_s"] < 6.0
    assert result["mission_time_s"] > result["time_s"]


@pytest.mark.shared_data("tracks/eufs/skidpad.csv")
@pytest.mark.slow
def test_skidpad_two_right_two_left_timed_on_the_second_of_each(tmp_path) -> None:
    summary = _run("skidpad", tmp_path)
    assert {"summary.json", "report.html", "run_log.npz"} <= {p.name for p in tmp_path.iterdir()}
    assert summary["mission"] == "skidpad"
    assert summary["finished"], summary["stop_reason"]
    assert summary["cones_hit"] == 0
    assert summary["off_track"] == 0
    result = summary["mission_result"]
    assert [lap["side"] for lap in result["laps"]] == ["right", "right", "left", "left"]
    assert len(result["gate_passes_s"]) == 5
    right, left = result["right_timed_lap_s"], result["left_timed_lap_s"]
    assert right == result["laps"][1]["time_s"] and left == result["laps"][3]["time_s"]
    assert result["mean_timed_lap_s"] == pytest.approx(0.5 * (right + left), abs=2e-3)
    # a 9.1 m circle at 1.5 g takes 4.9 s; the profile plans with 0.8 of it: about 5.5 s
    assert 4.8 < result["min_mean_lap_s"] < 5.1
    for lap in (right, left):
        assert result["min_mean_lap_s"] <= lap <= 1.3 * result["min_mean_lap_s"]
    assert result["ratio"] == pytest.approx(result["mean_timed_lap_s"]
                                            / result["min_mean_lap_s"], abs=2e-3)
