"""The explored lap in the mission result (issue 45): its time against the friction-limited
minimum of the true centreline, for the missions that drive an unseen track."""

from __future__ import annotations

import math

import pytest

from common.car import CarConfig
from orchestrator.mission_result import mission_result
from planner.speed_profile import min_lap_time_s
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


def test_no_explored_lap_no_ratio() -> None:
    track = load_track(str(shared_data("tracks", "eufs", "small_track.csv")))
    for lap in (None, math.nan):
        result = mission_result("autocross", track, CarConfig(), None, None, explored_lap_s=lap)
        assert result == {"mission_time_s": None}
