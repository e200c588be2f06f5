"""The explored lap in the mission result (issue 45): its time against the friction-limited
minimum of the true centreline, for the missions that drive an unseen track."""

from __future__ import annotations

import math

import numpy as np
import pytest

from common.car import CarConfig
from orchestrator.mission_result import mission_result
from planner.speed_profile import min_lap_time_s, min_standing_lap_time_s
from simulator.tracks import load_track
from support.shared_data import shared_data


@pytest.mark.parametrize("mission", ["trackdrive", "autocross"])
def test_the_explored_lap_is_given_against_the_minimum(mission: str) -> None:
    track = load_track(str(shared_data("tracks", "eufs", "small_track.csv")))
    car = CarConfig()
    t_min = min_lap_time_s(track.centreline_xy_m, car)
    result = mission_result(mission, track, car, None, 40.0, explored_lap_s=1.5 * t_min)
    assert result["min_lap_s"] == pytest.approx(t_min, abs=1e-3)
    assert result["explored_lap_s"] == pytest.approx(1.5 * t_min, abs=1e-3)
    assert result["explored_ratio"] == pytest.approx(1.5, abs=1e-3)
    t_standing = min_standing_lap_time_s(track.centreline_xy_m, car)
    assert result["min_standing_lap_s"] == pytest.approx(t_standing, abs=1e-3)
    assert result["explored_standing_ratio"] == pytest.approx(1.5 * t_min / t_standing, abs=1e-3)


def test_no_explored_lap_no_ratio() -> None:
    track = load_track(str(shared_data("tracks", "eufs", "small_track.csv")))
    for lap in (None, math.nan):
        result = mission_result("autocross", track, CarConfig(), None, None, explored_lap_s=lap)
        assert result == {"mission_time_s": None}


def test_the_view_ceiling_is_the_lap_held_to_the_pace_in_view() -> None:
    track = load_track(str(shared_data("tracks", "eufs", "small_track.csv")))
    car = CarConfig()
    t_min = min_lap_time_s(track.centreline_xy_m, car)
    result = mission_result("autocross", track, car, None, 40.0, explored_lap_s=2.0 * t_min,
                            explored_view=(17.0, 12.9))
    assert result["explored_view_m"] == pytest.approx(17.0)
    assert result["view_speed_mps"] == pytest.approx(12.9)
    held = min_lap_time_s(track.centreline_xy_m, car, max_speed_mps=12.9)
    assert result["view_ceiling_ratio"] == pytest.approx(held / t_min, abs=1e-3)
    assert 1.0 < result["view_ceiling_ratio"] < result["explored_ratio"]
    # in view more than the car's top speed needs: the friction limit itself
    free = mission_result("autocross", track, car, None, 40.0, explored_lap_s=2.0 * t_min,
                          explored_view=(200.0, 2.0 * car.top_speed_mps))
    assert free["view_ceiling_ratio"] == pytest.approx(1.0)


def test_the_summary_table_shows_the_explored_lap_against_its_ceiling() -> None:
    from orchestrator.summary_table import summary_rows

    rows = dict(summary_rows({"mission_result": {
        "explored_ratio": 1.68, "explored_standing_ratio": 1.52, "explored_view_m": 16.71,
        "view_speed_mps": 12.74, "view_ceiling_ratio": 1.501}}))
    assert rows["explored / friction limit"] == "1.680"
    assert rows["explored / standing start"] == "1.520"
    assert rows["in view while exploring"] == "16.7 m: at most 12.7 m/s, 1.50x at best"
    plain = dict(summary_rows({"mission_result": {"mission_time_s": 3.0}}))
    assert "explored / friction limit" not in plain and "in view while exploring" not in plain


def test_a_standing_lap_loses_the_launch_to_a_flying_one() -> None:
    """On a circle so wide that the top speed caps the lap, the standing lap loses the time
    of the launch to the flying one: v / (2 a) at drive acceleration a, a little more where
    the friction circle takes some of it for the bend."""
    car = CarConfig()
    radius_m = 400.0
    angle = np.linspace(0.0, 2.0 * math.pi, 800, endpoint=False)
    circle = radius_m * np.c_[np.sin(angle), 1.0 - np.cos(angle)]  # from (0, 0) facing +x
    flying = min_lap_time_s(circle, car)
    standing = min_standing_lap_time_s(circle, car)
    v = car.top_speed_mps
    assert flying == pytest.approx(2.0 * math.pi * radius_m / v, rel=2e-3)
    lateral_share = (v * v / radius_m) / car.max_lateral_accel_mps2
    drive_low = car.max_drive_accel_mps2 * math.sqrt(1.0 - lateral_share ** 2)
    launch_s = standing - flying
    assert v / (2.0 * car.max_drive_accel_mps2) - 0.01 <= launch_s
    assert launch_s <= v / (2.0 * drive_low) + 0.01
