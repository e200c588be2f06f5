"""The least gap between the car's outline and a cone's base over a run
(simulator/clearance.py): hand-made geometry, and agreement with the simulator's own hit test."""

from __future__ import annotations

import math

import numpy as np
import pytest

from common.car import CarConfig
from simulator.clearance import REACH_M, least_clearance, outline_gaps_m, run_clearance
from simulator.tracks import load_track
from simulator.vehicle import Vehicle

REAR_M, FRONT_M, HALF_WIDTH_M = -0.5, 2.5, 0.7


def test_the_gap_to_a_centre_is_measured_from_the_nearest_side_or_corner() -> None:
    cones = np.array([[3.0, 0.0], [1.0, 1.0], [3.0, 1.0], [-1.5, -0.7], [1.0, 0.2]])
    at_origin = np.zeros((len(cones), 3))
    gaps = outline_gaps_m(at_origin, cones, REAR_M, FRONT_M, HALF_WIDTH_M)
    np.testing.assert_allclose(gaps, [0.5, 0.3, math.hypot(0.5, 0.3), 1.0, 0.0], atol=1e-12)
    # turned a quarter left, the nose points along +y
    turned = np.tile([0.0, 0.0, math.pi / 2.0], (2, 1))
    np.testing.assert_allclose(
        outline_gaps_m(turned, [[0.0, 3.0], [-1.0, 1.0]], REAR_M, FRONT_M, HALF_WIDTH_M),
        [0.5, 0.3], atol=1e-12)


def test_a_pass_by_a_cone_is_as_near_as_it_is_beside_it() -> None:
    x = np.linspace(-10.0, 10.0, 201)
    poses = np.column_stack([x, np.zeros_like(x), np.zeros_like(x)])
    cones = np.array([[0.0, 1.2], [4.0, -30.0]])
    least = least_clearance(poses, cones, 0.1, REAR_M, FRONT_M, HALF_WIDTH_M)
    assert least.cone == 0
    assert least.gap_m == pytest.approx(1.2 - HALF_WIDTH_M - 0.1)
    # it is beside the cone from the rear (x = 0.5 behind it) to the nose (x = 2.5 before it)
    assert -2.5 <= x[least.sample] <= 0.5


def test_a_cone_beyond_reach_or_a_pose_that_is_nan_is_not_measured() -> None:
    far = least_clearance([[0.0, 0.0, 0.0]], [[0.0, REACH_M + 5.0]], 0.1,
                          REAR_M, FRONT_M, HALF_WIDTH_M)
    assert far.cone == -1 and math.isinf(far.gap_m)
    nan_pose = least_clearance([[math.nan, 0.0, 0.0], [0.0, 0.0, 0.0]], [[0.0, 1.0]], 0.1,
                               REAR_M, FRONT_M, HALF_WIDTH_M)
    assert nan_pose.sample == 1 and nan_pose.gap_m == pytest.approx(1.0 - HALF_WIDTH_M - 0.1)


def test_a_negative_gap_is_a_cone_the_simulator_counts_as_touched() -> None:
    track = load_track("gen:1")
    car = CarConfig()
    vehicle = Vehicle(car)
    rng = np.random.default_rng(5)
    # poses near the boundaries: every cone's side, at random offsets and headings
    picks = rng.choice(len(track.cones_xy_m), 300)
    poses = np.column_stack([track.cones_xy_m[picks] + rng.uniform(-2.5, 2.5, (300, 2)),
                             rng.uniform(-math.pi, math.pi, 300)])
    touched_any = near_any = 0
    for pose in poses:
        vehicle.state.x_m, vehicle.state.y_m, vehicle.state.yaw_rad = pose
        touched = bool(track.cones_touched(vehicle.footprint_corners()))
        summary = run_clearance([0.0], [pose], track, car)
        gap = summary["gap_m"]
        assert gap is not None
        assert touched == (float(gap) < 0.0) or abs(float(gap)) <= 1e-3  # (rounded to mm)
        touched_any += touched
        near_any += 0.0 <= float(gap) < 0.3
    assert touched_any > 20 and near_any > 20  # both sides of the line were tried


def test_the_summary_table_shows_the_least_clearance_after_the_off_track_events() -> None:
    from orchestrator.summary_table import summary_rows

    rows = summary_rows({"off_track": 0, "least_clearance": {
        "gap_m": 0.009, "cone": 33, "xy_m": [19.5, 4.5], "time_s": 15.87}})
    names = [name for name, _ in rows]
    assert names[names.index("off track") + 1] == "least clearance (m)"
    assert dict(rows)["least clearance (m)"] == "0.009 (cone 33 at 15.87 s)"
    none_near = dict(summary_rows({"least_clearance": {"gap_m": None}}))
    assert "least clearance (m)" not in none_near
