"""The known paths of acceleration and skidpad, built from mapped cones: on the rules' layouts
with noisy cones, rotated and offset from the car, and with only the cones a car sees at its
start."""

from __future__ import annotations

import math

import numpy as np

from common.messages import ConeColour
from planner.acceleration_path import acceleration_path
from planner.skidpad_path import skidpad_path

BLUE, YELLOW = int(ConeColour.BLUE), int(ConeColour.YELLOW)
ORANGE, BIG = int(ConeColour.ORANGE), int(ConeColour.BIG_ORANGE)
R_IN, R_OUT, R_MID = 7.625, 10.625, 9.125
"""The rules' skidpad radii (m): inner, outer, the lane's middle."""
FRONT_M = 2.25


def _rotate(xy: np.ndarray, yaw: float, offset: tuple[float, float]) -> np.ndarray:
    c, s = math.cos(yaw), math.sin(yaw)
    return np.c_[xy[:, 0] * c - xy[:, 1] * s + offset[0], xy[:, 0] * s + xy[:, 1] * c + offset[1]]


def _skidpad_layout(noise_m: float = 0.03, seed: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """A rules skidpad in its own frame: the gate at (15, 0), driving +x; the right circle's
    centre at (15, -9.125), the left's at (15, 9.125); entry lane from x = 5, exit lane to a
    closing row of cones at x = 36. Cones (N, 2) with noise, colours (N,)."""
    rng = np.random.default_rng(seed)
    pts, cols = [], []
    for cy, inner, outer in ((-R_MID, YELLOW, BLUE), (R_MID, BLUE, YELLOW)):
        centre = np.array([15.0, cy])
        for radius, colour, n in ((R_IN, inner, 16), (R_OUT, outer, 13)):
            for a in np.linspace(0.0, 2.0 * math.pi, n, endpoint=False):
                p = centre + radius * np.array([math.cos(a), math.sin(a)])
                if radius == R_OUT and abs(p[1]) < 3.0:  # the lanes' openings at the gate
                    continue
                pts.append(p)
                cols.append(colour)
    for x, y in [(13.5, 1.5), (13.5, -1.5), (16.5, 1.5), (16.5, -1.5)]:
        pts.append(np.array([x, y]))
        cols.append(BIG)
    for x in (5.0, 8.0, 24.0, 28.0, 32.0, 36.0):
        for y in (1.6, -1.6):
            pts.append(np.array([x, y]))
            cols.append(ORANGE)
    for y in (0.55, -0.55):
        pts.append(np.array([36.0, y]))
        cols.append(ORANGE)
    xy = np.array(pts) + rng.normal(0.0, noise_m, (len(pts), 2))
    return xy, np.array(cols)


def _along_path(points: np.ndarray, s_m: np.ndarray) -> np.ndarray:
    s = np.r_[0.0, np.cumsum(np.hypot(*np.diff(points, axis=0).T))]
    return np.c_[np.interp(s_m, s, points[:, 0]), np.interp(s_m, s, points[:, 1])]


def test_skidpad_path_is_the_rules_figure_of_eight_through_the_gate() -> None:
    yaw, offset = 0.4, (3.0, -2.0)  # the layout turned and moved against the car's frame
    xy, col = _skidpad_layout()
    cones = _rotate(xy, yaw, offset)
    path = skidpad_path(cones, col, None, tuple(_rotate(np.array([[0.0, 0.0]]), yaw, offset)[0]),
                        yaw + 0.03)
    assert path is not None and path.complete
    local = _rotate(path.points_xy_m - np.array(offset), -yaw, (0.0, 0.0))
    # five passes through the gate, a lap of the lane's middle apart
    gate = _rotate(_along_path(path.points_xy_m, path.timing_s_m) - np.array(offset), -yaw,
                   (0.0, 0.0))
    assert len(path.timing_s_m) == 5
    assert np.allclose(gate, [15.0, 0.0], atol=0.15)
    assert np.allclose(np.diff(path.timing_s_m), 2.0 * math.pi * R_MID, rtol=0.005)
    # each lap on its circle's lane middle: right twice (y < 0), then left twice
    s = np.r_[0.0, np.cumsum(np.hypot(*np.diff(path.points_xy_m, axis=0).T))]
    for k, (cy, sign) in enumerate(((-R_MID, -1.0), (-R_MID, -1.0), (R_MID, 1.0), (R_MID, 1.0))):
        lap = local[(s > path.timing_s_m[k] + 1.0) & (s < path.timing_s_m[k + 1] - 1.0)]
        radius = np.hypot(lap[:, 0] - 15.0, lap[:, 1] - cy)
        assert np.allclose(radius, R_MID, atol=0.1), k
        assert np.all(lap[:, 1] * sign > -0.6), k
        # clockwise on the right, counter-clockwise on the left
        step = np.diff(lap, axis=0)
        turn = step[:-1, 0] * step[1:, 1] - step[:-1, 1] * step[1:, 0]
        assert np.all(np.sign(turn) == sign), k
    # the stop: in the exit lane, the front short of the closing cones at x = 36
    stop = _rotate(_along_path(path.points_xy_m, np.array([path.stop_s_m])) - np.array(offset),
                   -yaw, (0.0, 0.0))[0]
    assert abs(stop[1]) < 0.2
    assert 15.0 + 10.0 < stop[0] and stop[0] + FRONT_M <= 36.0 - 1.0


def test_skidpad_before_the_gate_is_seen_drives_only_as_far_as_the_cones_known() -> None:
    xy, col = _skidpad_layout()
    seen = (np.hypot(*xy.T) < 12.0) & (col != BIG)  # the entry lane, not yet the gate
    path = skidpad_path(xy[seen], col[seen], None, (0.0, 0.0), 0.0)
    assert path is not None and not path.complete
    assert len(path.timing_s_m) == 0
    assert path.stop_s_m <= 12.0
    assert np.all(np.abs(path.points_xy_m[:, 1]) < 1e-9)


def _acceleration_layout(one_side: bool = False, noise_m: float = 0.03,
                         seed: int = 2) -> tuple[np.ndarray, np.ndarray]:
    """The rules' acceleration lane in its own frame (3 m wide, along +x): the start gate at
    x = 3, the finish gate 75 m on, the run-off to a closing row at x = 103."""
    rng = np.random.default_rng(seed)
    pts, cols = [], []
    for x in np.arange(8.0, 78.0, 5.0):
        for y, colour in ((1.5, BLUE), (-1.5, YELLOW)):
            if one_side and y < 0:
                continue
            pts.append((x, y))
            cols.append(colour)
    for x in (3.0, 78.0):
        for y in (1.5, -1.5):
            pts.append((x, y))
            cols.append(BIG)
    for x in np.arange(83.0, 104.0, 5.0):
        for y in (1.5, -1.5):
            pts.append((x, y))
            cols.append(ORANGE)
    for y in (0.75, -0.75):
        pts.append((103.0, y))
        cols.append(ORANGE)
    xy = np.array(pts, np.float64) + rng.normal(0.0, noise_m, (len(pts), 2))
    return xy, np.array(cols)


def test_acceleration_path_runs_down_the_middle_of_a_turned_lane() -> None:
    yaw, offset = -0.087, (0.3, 0.2)  # the car starts 5 degrees to the lane, off its middle
    xy, col = _acceleration_layout()
    cones = _rotate(xy, yaw, offset)
    path = acceleration_path(cones, col, None, (0.0, 0.0), 0.0)
    assert path is not None
    local = _rotate(path.points_xy_m - np.array(offset), -yaw, (0.0, 0.0))
    assert np.all(np.abs(local[:, 1]) < 0.05)
    car = _rotate(-np.array([offset]), -yaw, (0.0, 0.0))[0]  # the car in the lane's frame
    assert abs(local[0, 0] - car[0]) < 0.05  # from the car's place on the lane's axis
    start, finish = local[0, 0] + path.timing_s_m
    assert abs(start - 3.0) < 0.1 and abs(finish - 78.0) < 0.1
    stop = local[0, 0] + path.stop_s_m
    assert finish + 15.0 < stop and stop + FRONT_M <= 103.0 - 1.0


def test_acceleration_path_with_one_side_mapped_keeps_half_a_lane_from_it() -> None:
    xy, col = _acceleration_layout(one_side=True)
    path = acceleration_path(xy, col, None, (0.0, 0.0), 0.0, lane_width_m=3.0)
    assert path is not None
    assert np.all(np.abs(path.points_xy_m[:, 1]) < 0.1)


def test_acceleration_path_at_the_start_knows_the_finish_from_the_rules() -> None:
    """Only the cones within 15 m are mapped: the finish is 75 m past the start gate."""
    xy, col = _acceleration_layout()
    seen = np.hypot(*xy.T) < 15.0
    path = acceleration_path(xy[seen], col[seen], None, (0.0, 0.0), 0.0)
    assert path is not None
    assert np.allclose(path.timing_s_m, [3.0, 78.0], atol=0.1)
    # the lane's direction from 15 m of cones: refitted as the car sees more of it
    points = path.points_xy_m
    assert np.all(np.abs(points[:, 1]) < 0.05 + 0.005 * points[:, 0])


def test_no_cone_no_path() -> None:
    empty = np.zeros((0, 2))
    none = np.zeros(0, np.int64)
    assert acceleration_path(empty, none, None, (0.0, 0.0), 0.0) is None
    assert skidpad_path(empty, none, None, (0.0, 0.0), 0.0) is None
