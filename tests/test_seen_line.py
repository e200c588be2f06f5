"""The racing line through the cones seen while exploring (planner/seen_line.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from common.car import CarConfig
from common.messages import ConeColour
from planner.baseframe import SplineBaseframe
from planner.config import PlannerConfig
from planner.exploration_speed import free_sides_m, passage_room_m
from planner.manoeuvres import ManoeuvreGenerator
from planner.seen_line import HOLD_AHEAD_M, seen_racing_frame
from support.exploring_frames import gates_frame

CONFIG = PlannerConfig()
CAR = CarConfig()
GENERATOR = ManoeuvreGenerator(CONFIG, CAR)
ROOM_M = 1.5


def _bend(width_m: float, radius_m: float = 10.0, turn_rad: float = math.pi / 2,
          spacing_m: float = 2.5) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A lane ``width_m`` wide: 15 m straight along x, a left bend of ``radius_m`` (its middle)
    through ``turn_rad``, 25 m straight. Its middle (M, 2) every 0.25 m, its cones (N, 2)
    every ``spacing_m`` on either side and their colours (N,) (blue left, yellow right)."""
    pieces = [np.stack([np.arange(-15.0, 0.0, 0.25), np.zeros(60)], axis=1)]
    arc = np.arange(0.0, radius_m * turn_rad, 0.25) / radius_m
    pieces.append(np.stack([radius_m * np.sin(arc), radius_m * (1.0 - np.cos(arc))], axis=1))
    end = np.array([radius_m * math.sin(turn_rad), radius_m * (1.0 - math.cos(turn_rad))])
    along = np.arange(0.0, 25.0, 0.25)[:, None] * np.array([math.cos(turn_rad),
                                                             math.sin(turn_rad)])
    pieces.append(end + along)
    middle = np.vstack(pieces)
    step = np.gradient(middle, axis=0)
    normal = np.stack([-step[:, 1], step[:, 0]], axis=1)
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    every = int(round(spacing_m / 0.25))
    left = middle[::every] + 0.5 * width_m * normal[::every]
    right = middle[::every] - 0.5 * width_m * normal[::every]
    cones = np.vstack([left, right])
    colours = np.r_[np.full(len(left), ConeColour.BLUE), np.full(len(right), ConeColour.YELLOW)]
    return middle, cones, colours


def _line(frame: SplineBaseframe, cones: np.ndarray, **kw: object) -> SplineBaseframe | None:
    return seen_racing_frame(frame, cones, GENERATOR.circle_offsets_m, GENERATOR.required_m,
                             ROOM_M, CONFIG, **kw)  # type: ignore[arg-type]


@pytest.fixture(scope="module")
def wide_bend() -> tuple[np.ndarray, np.ndarray, SplineBaseframe, SplineBaseframe]:
    """A 5 m lane's bend, every cone seen from the start: cones, colours, the gates' frame and
    the line."""
    _, cones, colours = _bend(5.0)
    frame = gates_frame(cones, colours, -12.0, 0.0, 0.0)
    line = _line(frame, cones)
    assert line is not None
    return cones, colours, frame, line


def test_the_line_bends_less_than_the_gates_path(wide_bend) -> None:
    _, _, frame, line = wide_bend
    # the gates' path bends at the bend's 1/10 1/m; the line through a 5 m lane keeping 1.5 m
    # of room may move 0.75 m either way of the middle, and opens the bend
    assert np.max(np.abs(frame.curvature_1pm)) == pytest.approx(0.1, abs=0.02)
    assert np.max(np.abs(line.curvature_1pm)) < 0.85 * np.max(np.abs(frame.curvature_1pm))
    # it cuts the inside at the bend's middle (the bend is to the left: the line lies left)
    apex = np.array([10.0 * math.sin(math.pi / 4), 10.0 * (1.0 - math.cos(math.pi / 4))])
    s, d = frame.project(*line.xy_m[np.argmin(np.linalg.norm(line.xy_m - apex, axis=1))])
    assert d > 0.3


def test_the_line_keeps_the_room_it_was_asked_for(wide_bend) -> None:
    cones, _, frame, line = wide_bend
    room = passage_room_m(line.xy_m, line.heading_rad, cones, GENERATOR.circle_offsets_m,
                          GENERATOR.required_m, CONFIG.offsets_wide_max_m)
    # the bounds hold the body parallel to the gates' path; on the line it turns by the two
    # headings' difference, which swings its furthest circle that much further to a side
    s, _ = frame.project_many(line.xy_m)
    turned = np.abs(line.heading_rad - np.interp(s, frame.s_m, frame.heading_rad))
    swing = 2.0 * np.max(np.abs(GENERATOR.circle_offsets_m)) * np.sin(turned)
    assert np.all(room >= ROOM_M - swing - 0.02)


@pytest.mark.parametrize("seen_to_y_m", [12.0, 12.7, 13.4])
def test_the_line_ends_where_the_gates_path_ends(seen_to_y_m: float) -> None:
    # the track seen ends where the gates' path does, whatever its length: the view the
    # exploring speed is allowed is the same on the line
    _, cones, colours = _bend(5.0)
    seen = cones[:, 1] < seen_to_y_m
    frame = gates_frame(cones[seen], colours[seen], -12.0, 0.0, 0.0)
    line = _line(frame, cones[seen])
    assert line is not None
    assert np.linalg.norm(line.xy_m[-1] - frame.xy_m[-1]) < 0.05


def test_a_lane_without_the_room_keeps_the_gates_path() -> None:
    _, cones, colours = _bend(3.0)
    frame = gates_frame(cones, colours, -12.0, 0.0, 0.0)
    # the middle of a 3 m lane has about 1.1 m of room: nowhere to move keeping 1.5 m
    assert _line(frame, cones) is None


def test_the_track_beyond_one_side_seen_is_the_middle() -> None:
    _, cones, colours = _bend(5.0)
    # the right side (the bend's outside) seen only up to 5 m into the bend
    keep = (colours == ConeColour.BLUE) | (cones[:, 0] < 5.0)
    frame = gates_frame(cones[keep], colours[keep], -12.0, 0.0, 0.0)
    line = _line(frame, cones[keep])
    assert line is not None
    beyond = frame.xy_m[:, 0] > 8.0
    s_line, d_line = frame.project_many(line.xy_m)
    on_frame = s_line > frame.s_m[beyond][0] + 2.0  # past a sample spacing beyond the seen
    assert np.max(np.abs(d_line[on_frame])) < 0.1


def test_the_line_near_the_car_is_held_where_the_last_plan_ran(wide_bend) -> None:
    cones, colours, _, line = wide_bend
    # the car 1 m along the last line; a plan later the gates' path is built from there
    car_xy = line.frenet_to_xy(line.project(-5.0, 0.0)[0], 0.0)
    frame = gates_frame(cones, colours, car_xy[0], car_xy[1], 0.0)
    shifted = SplineBaseframe(line.xy_m + np.array([0.0, 0.3]), False, resample_m=1.0,
                              smoothing_m=0.0, step_m=0.25)
    held = _line(frame, cones, car_xy_m=(car_xy[0], car_xy[1]), previous=shifted)
    assert held is not None
    s_car = held.project(*car_xy)[0]
    near = (held.s_m >= s_car) & (held.s_m <= s_car + HOLD_AHEAD_M - 1.0)
    _, d_prev = shifted.project_many(held.xy_m[near])
    assert np.max(np.abs(d_prev)) < 0.08  # on the last plan's line, 0.3 m off this plan's own
    free = _line(frame, cones)
    assert free is not None
    _, d_free = free.project_many(held.xy_m[near])
    assert np.min(np.abs(d_free)) > 0.15


def test_free_sides_of_a_lane_middle_are_equal_and_sum_to_its_room() -> None:
    middle, cones, _ = _bend(4.0)
    straight = middle[:40]  # the first 10 m, straight along x
    heading = np.zeros(len(straight))
    left, right, blocked = free_sides_m(straight, heading, cones, GENERATOR.circle_offsets_m,
                                        GENERATOR.required_m, 4.0)
    room = passage_room_m(straight, heading, cones, GENERATOR.circle_offsets_m,
                          GENERATOR.required_m, 4.0)
    assert not blocked.any()
    np.testing.assert_allclose(left, right, atol=1e-9)
    np.testing.assert_allclose(room, 2.0 * np.minimum(left, right))
    # 2 m to each side's cone centres, less the body's half width and the cone's margin
    expected = 2.0 - GENERATOR.required_m - (CAR.width_m / 2.0 - GENERATOR.circle_radius_m)
    assert np.median(left) == pytest.approx(expected, abs=0.15)


def test_the_hold_reads_the_last_frame_near_its_start_when_it_comes_round(wide_bend) -> None:
    cones, colours, _, line = wide_bend
    car_xy = line.frenet_to_xy(line.project(-5.0, 0.0)[0], 0.0)
    frame = gates_frame(cones, colours, car_xy[0], car_xy[1], 0.0)
    # the last frame 0.3 m left of the line, then round and back past the car 0.2 m right of
    # the lane's middle: nearer the car than its first stretch, the wrong stretch to hold to
    first = line.xy_m + np.array([0.0, 0.3])
    back_x = np.arange(25.0, -20.0, -0.5)
    round_trip = np.vstack([first, [[18.0, 40.0], [28.0, 30.0], [30.0, 10.0], [28.0, 1.0]],
                            np.stack([back_x, np.full(len(back_x), -0.2)], axis=1)])
    previous = SplineBaseframe(round_trip, False, resample_m=1.0, smoothing_m=0.0, step_m=0.25)
    held = _line(frame, cones, car_xy_m=(car_xy[0], car_xy[1]), previous=previous)
    assert held is not None
    s_car = held.project(*car_xy)[0]
    near = (held.s_m >= s_car) & (held.s_m <= s_car + HOLD_AHEAD_M - 1.0)
    # on the straight the last frame's first stretch is a function of x
    on_first = np.interp(held.xy_m[near, 0], first[:, 0], first[:, 1])
    np.testing.assert_allclose(held.xy_m[near, 1], on_first, atol=0.08)


def _planner_frame(cones: np.ndarray, colours: np.ndarray) -> SplineBaseframe:
    """The frame the planner explores on, with the line asked for, from the car at (-12, 0)
    heading along x with every cone of ``cones`` (N, 2) seen in ``colours`` (N,)."""
    from common.messages import ConeMap, MapState, PoseEstimate
    from planner.path_planner import PathPlanner

    n = len(cones)
    cone_map = ConeMap(xy_m=cones, covariance=np.tile(np.eye(2) * 0.01, (n, 1, 1)),
                       colour=np.asarray(colours, np.int64), size=np.ones(n, np.int64),
                       confidence=np.ones(n), ids=np.arange(n, dtype=np.int64))
    pose = PoseEstimate(0.0, -12.0, 0.0, 0.0, 5.0, 0.0, 0.0, np.eye(3) * 1e-4)
    planner = PathPlanner(PlannerConfig(exploration_line_room_m=ROOM_M), CAR)
    state = MapState(0.0, pose, cone_map, loop_closed=False)
    planner.start_autonomous(state)
    assert planner.explore(state) and planner.exploring
    assert planner.frame is not None
    return planner.frame


def test_the_planner_races_the_line_only_with_colours_in_the_map() -> None:
    """With colours the planner explores on the line (it bends less than the bend's middle);
    with the camera dead the gates, and the room beside them, are guessed, and it keeps the
    gates' path (measured: the line on EUFS Hairpin with the camera dead touched a cone
    before the stop it comes to either way)."""
    middle, cones, colours = _bend(5.0)
    middle = middle[(middle[:, 0] > -10.0) & (middle[:, 1] < 30.0)][::8]  # within the frames
    coloured = _planner_frame(cones, colours)
    _, d_coloured = coloured.project_many(middle)
    # the line may move 0.75 m either way of the middle (a 5 m lane, 1.5 m of room kept)
    assert 0.5 < np.max(np.abs(d_coloured)) < 0.75 + 0.1
    blind = _planner_frame(cones, np.full(len(cones), int(ConeColour.UNKNOWN)))
    _, d_blind = blind.project_many(middle)
    assert np.max(np.abs(d_blind)) < 0.2
    assert np.max(np.abs(blind.curvature_1pm)) == pytest.approx(0.1, abs=0.02)  # radius 10 m


@pytest.mark.shared_data("tracks/eufs/peanut.csv")
@pytest.mark.slow
def test_peanut_explored_on_the_line_is_clean_and_faster(tmp_path) -> None:
    """The whole stack on EUFS peanut (autocross, seed 3), with the line and without: both
    clean, the unseen lap on the line faster (measured 1.33x -> 1.24x the friction limit)."""
    from orchestrator.config import AppConfig
    from orchestrator.sim import SimOptions, run_sim
    from support.shared_data import shared_path

    track = str(shared_path("tracks", "eufs", "peanut.csv"))
    laps = {}
    for room_m in (0.0, ROOM_M):
        config = AppConfig()
        config.planner.exploration_line_room_m = room_m
        summary = run_sim(config, SimOptions(track=track, seed=3, mission="autocross",
                                             render=False, record=False,
                                             out_dir=tmp_path / f"room_{room_m}"))
        assert summary["finished"], summary["stop_reason"]
        assert summary["cones_hit"] == 0
        assert summary["off_track"] == 0
        laps[room_m] = summary["mission_result"]["explored_lap_s"]
    assert laps[ROOM_M] < 0.97 * laps[0.0]


def _curvature_problem(n: int, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray,
                                                    np.ndarray]:
    """A line's Gauss-Newton step as the seen line poses it: the curvature Jacobian (n-2, n)
    of a wavy open line (second differences over 1.5 m, tridiagonal: a'a is singular with both
    ends free), a target and offset bounds of a 3-5 m lane keeping 1.5 m of room."""
    rng = np.random.default_rng(seed)
    step_m = 1.5
    a = np.zeros((n - 2, n))
    for i in range(n - 2):
        a[i, i:i + 3] = np.array([1.0, -2.0, 1.0]) / step_m**2
    b = 0.1 * np.sin(np.linspace(0.0, 3.0, n - 2)) + 0.01 * rng.standard_normal(n - 2)
    half_room_m = 0.5 * (rng.uniform(3.0, 5.0, n) - ROOM_M)
    return a, b, -half_room_m, half_room_m


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_the_lines_bounded_least_squares_is_scipys_bvls(seed: int) -> None:
    """DAQP's solve of the line's step is the optimum scipy's bvls finds (the same problem,
    solved 30-50x faster): within the bounds, the same least sum of squares, and, where a'a
    is singular (an optimum along a straight line's free tilt is not unique, and DAQP
    regularises), offsets within a millimetre of bvls's."""
    from scipy.optimize import lsq_linear

    from planner.racing_line import bounded_least_squares

    a, b, lower, upper = _curvature_problem(34, seed)
    x = bounded_least_squares(a, b, lower, upper)
    reference = lsq_linear(a, b, bounds=(lower, upper), method="bvls").x
    assert np.all((x >= lower - 1e-9) & (x <= upper + 1e-9))
    assert np.any(np.isclose(x, lower) | np.isclose(x, upper))  # some bounds bind
    assert np.sum((a @ x - b) ** 2) == pytest.approx(np.sum((a @ reference - b) ** 2),
                                                     rel=1e-9)
    assert np.max(np.abs(x - reference)) < 1e-3


def test_a_failed_daqp_solve_falls_back_to_bvls(monkeypatch, caplog) -> None:
    """When DAQP reports no optimum (exit flag -4: its iteration limit), the step is bvls's,
    and the fallback is logged."""
    import daqp
    from scipy.optimize import lsq_linear

    from planner.racing_line import bounded_least_squares

    a, b, lower, upper = _curvature_problem(20, 4)
    monkeypatch.setattr(daqp, "solve", lambda *args, **kw: (np.zeros(20), 0.0, -4, {}))
    with caplog.at_level("WARNING", logger="planner.racing_line"):
        x = bounded_least_squares(a, b, lower, upper)
    assert np.allclose(x, lsq_linear(a, b, bounds=(lower, upper), method="bvls").x)
    assert "daqp exit flag -4" in caplog.text
