"""Once a lap is mapped, the camera's tentative cones (ids < 0) do not stop the car.

Tentative cones extend the exploring planner's view beyond the LiDAR's landmarks. Their
positions carry the camera's range error (0.3-0.4 m at 15-20 m). On a closed (mapped) frame
every real cone is a landmark already, so a tentative one can only be an error. Found on EPFL's
``track_2`` (seed 1): a tentative cone in the middle of the lane, 16 m ahead at 16 m/s in the
second lap, stopped the car. The stop's path hit 3 cones.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
import pytest
from planner_closed_loop_helpers import cone_map

from common.messages import ConeMap, MapState, Plan, PoseEstimate
from orchestrator.config import AppConfig
from planner.path_planner import PathPlanner
from simulator.tracks import Track, load_track

AHEAD_M = 15.0
"""Where the stray cone stands, along the centre line ahead of the car (m)."""


def _with_cone(cones: ConeMap, xy_m: np.ndarray, cone_id: int) -> ConeMap:
    return ConeMap(xy_m=np.vstack([cones.xy_m, xy_m]),
                   covariance=np.vstack([cones.covariance, np.eye(2)[None] * 0.09]),
                   colour=np.append(cones.colour, 0), size=np.append(cones.size, 1),
                   confidence=np.append(cones.confidence, 0.5),
                   ids=np.append(cones.ids, cone_id))


class Mapped(NamedTuple):
    config: AppConfig
    track: Track
    cones: ConeMap
    pose: PoseEstimate
    stray_xy_m: np.ndarray


@pytest.fixture(scope="module")
def mapped() -> Mapped:
    """gen:2 mapped (all its cones landmarks), the car on its centre line at 12 m/s, and the
    point of the centre line AHEAD_M ahead."""
    config = AppConfig()
    config.planner.racing_line = False  # the centre line: the same frame, built at once
    track = load_track("gen:2")
    centre = track.centreline_xy_m
    step_m = float(np.median(np.hypot(*np.diff(centre, axis=0).T)))
    i = 10
    j = i + int(round(AHEAD_M / step_m))
    dx, dy = centre[i + 1] - centre[i]
    pose = PoseEstimate(0.0, float(centre[i, 0]), float(centre[i, 1]), math.atan2(dy, dx),
                        12.0, 0.0, 0.0, np.eye(3) * 1e-4)
    cones = cone_map(track.cones_xy_m, track.colours)
    return Mapped(config, track, cones, pose, centre[j])


def _plan(mapped: Mapped, cone_id: int) -> Plan:
    config, track, cones, pose, stray_xy = mapped
    planner = PathPlanner(config.planner, config.car)
    for p in track.centreline_xy_m[::3]:
        planner.book.record(float(p[0]), float(p[1]))
    planner.start_autonomous(MapState(0.0, pose, cones, loop_closed=True))
    assert planner.frame is not None and planner.frame.closed
    state = MapState(0.1, pose, _with_cone(cones, stray_xy[None], cone_id), loop_closed=True)
    return planner.plan(state, 0.1)


def test_a_tentative_cone_in_the_lane_of_a_mapped_lap_does_not_stop_the_car(
        mapped: Mapped) -> None:
    plan = _plan(mapped, cone_id=-1)
    assert plan.chosen_index >= 0
    assert plan.target_speed_mps > 10.0


def test_a_landmark_in_the_same_place_does(mapped: Mapped) -> None:
    """The stray cone is in the way: as a landmark (a cone the LiDAR mapped) no manoeuvre
    clears it, and the car stops."""
    plan = _plan(mapped, cone_id=10_000)
    assert plan.chosen_index == -1
