"""Issue 45's invariant in the closed loop: exploring at pace, the car can always stop within
the track it has seen. A straight lane whose cones simply end is the case where it must: the
whole stack (simulated sensors, SLAM, planner, controller, supervisor) drives it as an
autocross, and the car has to stand before the last gate it saw, touching nothing."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

LANE_END_M = 60.0
HALF_WIDTH_M = 1.75


def _lane_csv(path: Path) -> Path:
    """An EUFS track file: a 3.5 m lane along +x, a gate every 3 m from x = -6 m to
    ``LANE_END_M``, nothing beyond; the car starts at the origin heading +x."""
    rows = ["tag,x,y,direction,x_variance,y_variance,xy_covariance"]
    for x in np.arange(-6.0, LANE_END_M + 0.1, 3.0):
        rows.append(f"blue,{x:.1f},{HALF_WIDTH_M},0,0,0,0")
        rows.append(f"yellow,{x:.1f},{-HALF_WIDTH_M},0,0,0,0")
    rows.append("car_start,0.0,0.0,0,0,0,0")
    path.write_text("\n".join(rows) + "\n")
    return path


def _drive_lane(tmp_path: Path) -> tuple[dict, np.ndarray, np.ndarray, np.ndarray]:
    """An autocross of the lane (seed 1): the summary, and the run log's time (s), rear-axle x
    (m) and speed (m/s) from the truth."""
    from orchestrator.config import AppConfig
    from orchestrator.sim import SimOptions, run_sim

    track = _lane_csv(tmp_path / "lane.csv")
    out = tmp_path / "run"
    summary = run_sim(AppConfig(), SimOptions(track=str(track), seed=1, mission="autocross",
                                              render=False, record=False, out_dir=out))
    log = np.load(out / "run_log.npz")
    return summary, log["t_s"], log["truth"][:, 0], log["truth"][:, 3]


def test_exploring_a_lane_whose_cones_end_the_car_stands_before_its_last_gate(
        tmp_path: Path) -> None:
    summary, _, x_m, speed_mps = _drive_lane(tmp_path)
    assert summary["cones_hit"] == 0 and summary["off_track"] == 0
    # no lap to finish: it stopped because the track it had seen ended, standing
    assert not summary["finished"]
    assert summary["stop_reason"] == "no manoeuvre"
    assert abs(speed_mps[-1]) < 0.2
    # the rear axle (the vehicle origin) never passed the last gate, and the stop was made
    # at the end of the lane, not short of it
    assert x_m.max() < LANE_END_M
    assert x_m[-1] > LANE_END_M - 5.0
    # and the lane was driven at pace, not at a crawl: the invariant, not a constant, held it
    assert speed_mps.max() > 10.0


def test_a_planner_that_stalls_as_the_lane_end_comes_into_view_is_ridden_out(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """No plan for 0.3 s at 12-13 m/s just as the lane's last gate comes into view (the end of
    the track seen stops moving on there, and the car is at the invariant's limit): the
    controller follows the last plan, slower as it ages, and the late cover
    (``planner.exploration_late_cover_s``) leaves that plan room enough that the supervisor
    never finds it short of a stop. The car still stands before the last gate, the run ended
    for want of a manoeuvre, not for a plan too old. (At a 0.2 s cover it ended "plan too old:
    0.220 s, its 12.0 m ahead do not cover a stop (12.2 m)".)"""
    import orchestrator.layers as layers

    stall_from_m, stall_s = 40.0, 0.3
    stalled_at: list[float] = []
    step = layers.DeliberativeLayer.step

    def stalling_step(self, now_s, map_state, go, driving):  # type: ignore[no-untyped-def]
        if not stalled_at and map_state.pose.x_m >= stall_from_m:
            stalled_at.append(now_s)
        if stalled_at and now_s < stalled_at[0] + stall_s:
            return None
        return step(self, now_s, map_state, go, driving)

    monkeypatch.setattr(layers.DeliberativeLayer, "step", stalling_step)
    summary, t_s, x_m, speed_mps = _drive_lane(tmp_path)
    assert stalled_at, "the car never reached the stall"
    at_stall = int(np.searchsorted(t_s, stalled_at[0]))
    assert speed_mps[at_stall] > 10.0  # at pace when the plans stopped
    assert summary["cones_hit"] == 0 and summary["off_track"] == 0
    assert summary["stop_reason"] == "no manoeuvre"
    assert x_m.max() < LANE_END_M and x_m[-1] > LANE_END_M - 5.0
