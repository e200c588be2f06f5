"""Closed loop with perfect pose: planner + controller drive laps of FSG with no cone hit, near
the friction-limited minimum lap time, on a kinematic bicycle and on simulator/vehicle.py."""

from __future__ import annotations

import pytest
from planner_closed_loop_helpers import run_closed_loop

from common.messages import AsState
from orchestrator.config import AppConfig
from planner.speed_profile import min_lap_time_s
from simulator.tracks import load_track
from support.shared_data import shared_path

FSG = shared_path("tracks", "amz_fssim", "FSG.yaml")


@pytest.mark.shared_data("tracks/amz_fssim/FSG.yaml")
@pytest.mark.parametrize("dynamic", [False, True], ids=["kinematic", "vehicle_model"])
@pytest.mark.slow
def test_fsg_two_laps_no_cone_hit_near_minimum_lap_time(dynamic: bool) -> None:
    config = AppConfig()
    if not dynamic:
        kinematic_controller(config)
    track = load_track(str(FSG))
    result = run_closed_loop(config, track, laps=2, max_time_s=90.0, dynamic=dynamic)
    assert result.cones_hit == set()
    assert result.off_track == 0
    assert result.final_state == AsState.FINISHED
    assert result.stop_reason.startswith("finished")
    assert result.lap_times_s, "no flying lap timed"
    t_min = min_lap_time_s(track.centreline_xy_m, config.car)
    assert min(result.lap_times_s) <= 1.25 * t_min


def kinematic_controller(config: AppConfig) -> None:
    """The controller set for the kinematic bicycle: it does not understeer and it answers the
    steering at once (no yaw lag to preview beyond the actuator's)."""
    config.controller.understeer_steer_rad = (0.0,) * len(config.controller.understeer_accel_mps2)
    config.controller.preview_time_s = 0.1


@pytest.mark.slow
def test_unknown_track_from_the_cone_map_default() -> None:
    config = AppConfig()
    kinematic_controller(config)
    track = load_track("default")
    result = run_closed_loop(config, track, laps=1, max_time_s=60.0)
    assert result.cones_hit == set()
    assert result.final_state == AsState.FINISHED


@pytest.mark.slow
def test_generated_track_fast_lap_stays_near_the_centreline() -> None:
    """gen:2 (long straights) on the vehicle model: the car must not weave at speed. With perfect
    pose the rear axle stays within 0.75 m of the centreline (half width 1.85 m, car 1.4 m wide),
    leaving about 0.3 m for localisation error before a cone is touched."""
    config = AppConfig()
    track = load_track("gen:2")
    result = run_closed_loop(config, track, laps=1, max_time_s=60.0, dynamic=True)
    assert result.cones_hit == set()
    assert result.off_track == 0
    assert result.final_state == AsState.FINISHED
    assert result.max_offset_m < 0.75
