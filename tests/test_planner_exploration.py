"""Autonomous exploration: the path through the gates of the cones seen so far, and a whole
autocross on small_track driven by the stack alone."""

from __future__ import annotations

import math

import numpy as np
import pytest

from common.messages import ConeColour
from planner.exploration_path import exploration_path

BLUE, YELLOW = int(ConeColour.BLUE), int(ConeColour.YELLOW)
UNKNOWN, BIG = int(ConeColour.UNKNOWN), int(ConeColour.BIG_ORANGE)


def _bend(n: int = 10, radius_m: float = 15.0, half_width_m: float = 1.75,
          spacing_m: float = 4.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A left bend from the origin heading +x: left cones (n, 2), right cones (n, 2), and the
    centreline at the same angles (n, 2)."""
    a = (np.arange(n) + 1) * spacing_m / radius_m
    centre = np.c_[radius_m * np.sin(a), radius_m - radius_m * np.cos(a)]
    inward = np.c_[-np.sin(a), np.cos(a)]
    return centre + half_width_m * inward, centre - half_width_m * inward, centre


def _distance_to(points: np.ndarray, line: np.ndarray) -> np.ndarray:
    return np.min(np.hypot(points[:, None, 0] - line[None, :, 0],
                           points[:, None, 1] - line[None, :, 1]), axis=1)


def _dense(line: np.ndarray) -> np.ndarray:
    t = np.linspace(0.0, 1.0, 20)[:, None]
    return np.concatenate([a + t * (b - a) for a, b in zip(line[:-1], line[1:], strict=True)])


def test_path_follows_the_middle_of_a_coloured_bend() -> None:
    left, right, centre = _bend()
    cones = np.r_[left, right]
    colours = np.r_[np.full(len(left), BLUE), np.full(len(right), YELLOW)]
    path = exploration_path(cones, colours, (0.0, 0.0), 0.0)
    assert len(path) >= 8
    assert np.all(_distance_to(path[1:], _dense(np.r_[[[0.0, 0.0]], centre])) < 0.2)


def test_one_side_unseen_keeps_half_a_track_inside_the_other() -> None:
    """Through a corner only the outer (right, yellow) side is seen: the path runs half a
    nominal width (1.75 m) inside it, on the centreline within the bend's chord error."""
    _, right, centre = _bend()
    path = exploration_path(right, np.full(len(right), YELLOW), (0.0, 0.0), 0.0,
                            track_width_m=3.5)
    assert len(path) >= 8
    assert np.all(_distance_to(path[1:], _dense(np.r_[[[0.0, 0.0]], centre])) < 0.3)


def test_cones_of_unknown_colour_take_the_side_they_lie_on() -> None:
    left, right, centre = _bend()
    cones = np.r_[left, right]
    path = exploration_path(cones, np.full(len(cones), UNKNOWN), (0.0, 0.0), 0.0)
    assert len(path) >= 8
    assert np.all(_distance_to(path[1:], _dense(np.r_[[[0.0, 0.0]], centre])) < 0.3)


def test_a_missing_cone_and_an_extra_cone_beside_the_track_change_little() -> None:
    """One left cone missing, and a stray cone 6 m beside the track (further than a track
    width): the path stays within 0.5 m of the centreline."""
    left, right, centre = _bend()
    left = np.delete(left, 4, axis=0)
    stray = centre[5] + np.array([0.0, -6.0])
    cones = np.r_[left, right, stray[None, :]]
    colours = np.r_[np.full(len(left), BLUE), np.full(len(right), YELLOW), [UNKNOWN]]
    path = exploration_path(cones, colours, (0.0, 0.0), 0.0)
    assert len(path) >= 8
    assert np.all(_distance_to(path[1:], _dense(np.r_[[[0.0, 0.0]], centre])) < 0.5)


def test_a_cone_mapped_twice_counts_once() -> None:
    """Before the loop closes the SLAM maps a cone seen long ago a second time, a few cm from
    the first. Through a corner with one side seen, a cone's twin is no neighbour that gives
    the boundary's direction: the path stays on the centreline (it ran 2.3 m off it)."""
    _, right, centre = _bend()
    rng = np.random.default_rng(4)
    twins = right + rng.normal(0.0, 0.02, right.shape)
    path = exploration_path(np.r_[right, twins], np.full(2 * len(right), YELLOW), (0.0, 0.0),
                            0.0, track_width_m=3.5)
    assert len(path) >= 8
    assert np.all(_distance_to(path[1:], _dense(np.r_[[[0.0, 0.0]], centre])) < 0.3)


def test_a_wide_gate_is_still_a_gate() -> None:
    """The track widens to 5.5 m (a bend's entry): the right cones lie 4 m to the side, beyond
    a nominal width (3.5 m); they are still paired with the left ones and the path runs in the
    middle (y = -1.25 m) instead of half a nominal width inside the left side (y = -0.25 m)."""
    x = np.array([3.0, 6.0, 9.0, 12.0])
    cones = np.r_[np.c_[x, np.full(4, 1.5)], np.c_[x, np.full(4, -4.0)]]
    colours = np.r_[np.full(4, BLUE), np.full(4, YELLOW)]
    path = exploration_path(cones, colours, (0.0, 0.0), 0.0, track_width_m=3.5)
    assert len(path) == 5
    assert np.allclose(path[1:, 1], -1.25, atol=1e-9)


def test_first_cones_of_unknown_colour_make_the_first_gate() -> None:
    """At the start the nearest cones' colours are not voted yet while the next blue cone
    already is (QR_Nov_2022's start): the first gate is the unknown pair beside the start,
    not the far blue cone with one unknown cone diagonally (whose 'boundary' then ran across
    the track and sent the car into the right side)."""
    cones = np.array([[1.8, 1.4], [2.1, -2.5], [4.2, 1.8], [4.9, -1.5], [5.8, 2.4],
                      [6.7, -1.0], [8.4, 3.2], [9.2, -0.2]])
    colours = np.array([UNKNOWN, UNKNOWN, BIG, BIG, BIG, BIG, BLUE, YELLOW])
    path = exploration_path(cones, colours, (0.0, 0.0), 0.0)
    assert len(path) >= 3
    assert np.allclose(path[1], [1.95, -0.55], atol=1e-9)
    # every point between the two sides' cones
    assert np.all((path[1:, 1] > -2.0) & (path[1:, 1] < 2.5))


def test_no_cone_ahead_gives_only_the_start() -> None:
    left, right, _ = _bend()
    cones = np.r_[left, right] - np.array([60.0, 0.0])  # all behind the car
    path = exploration_path(cones, np.full(len(cones), BLUE), (0.0, 0.0), 0.0)
    assert path.shape == (1, 2)
    empty = exploration_path(np.zeros((0, 2)), np.zeros(0), (1.0, 2.0), math.pi / 2)
    assert np.allclose(empty, [[1.0, 2.0]])


@pytest.mark.shared_data("tracks/eufs/small_track.csv")
@pytest.mark.slow
def test_autocross_on_small_track_is_driven_by_the_stack_alone(tmp_path) -> None:
    """No person drives: the stack explores its one lap from the cones it maps, no cone
    touched, and stops finished after the line."""
    from orchestrator.config import AppConfig
    from orchestrator.sim import SimOptions, run_sim
    from support.shared_data import shared_path

    config = AppConfig()
    track = str(shared_path("tracks", "eufs", "small_track.csv"))
    summary = run_sim(config, SimOptions(track=track, seed=3, mission="autocross",
                                         render=False, record=False, out_dir=tmp_path))
    assert summary["mission"] == "autocross"
    assert summary["exploration"] == "autonomous"
    assert summary["finished"], summary["stop_reason"]
    assert summary["laps_completed"] == 1
    assert summary["cones_hit"] == 0
    assert summary["off_track"] == 0
    assert summary["cone_hits"] == []


@pytest.mark.shared_data("tracks/eufs/peanut.csv")
@pytest.mark.slow
def test_autocross_on_peanut_crosses_the_waist(tmp_path) -> None:
    """The peanut's waist: the car sees the cones of the start again across it before its lap
    is done (the SLAM maps them twice until the loop closes), and the right lobe with the
    waist's cones looks like a loop of its own that misses the start. Both once stopped the
    car or put it into the cones."""
    from orchestrator.config import AppConfig
    from orchestrator.sim import SimOptions, run_sim
    from support.shared_data import shared_path

    track = str(shared_path("tracks", "eufs", "peanut.csv"))
    summary = run_sim(AppConfig(), SimOptions(track=track, seed=3, mission="autocross",
                                              render=False, record=False, out_dir=tmp_path))
    assert summary["finished"], summary["stop_reason"]
    assert summary["laps_completed"] == 1
    assert summary["cones_hit"] == 0
    assert summary["off_track"] == 0


def _ring(mission: str, radius_m: float, half_m: float, n_cones: int, speed_mps: float,
          extra_xy: np.ndarray | None = None, extra_colours: np.ndarray | None = None):
    """A planner for ``mission`` and a ring of blue (inside) and yellow cones ``half_m`` either
    side of a circle of ``radius_m`` that starts at the origin heading +x (plus ``extra_xy``
    of ``extra_colours``): the planner, the cones, their colours and ``state(t_s, angle,
    seen=None)``, the map state of a car ``angle`` (rad) round the ring at ``speed_mps`` that
    has mapped the cones ``seen`` (a mask; all when None)."""
    from planner_closed_loop_helpers import cone_map

    from common.messages import MapState, PoseEstimate
    from orchestrator.config import AppConfig
    from planner.path_planner import PathPlanner

    config = AppConfig()
    planner = PathPlanner(config.planner, config.car, mission)
    a = np.linspace(0.0, 2.0 * math.pi, n_cones, endpoint=False)
    centre = np.c_[radius_m * np.sin(a), radius_m - radius_m * np.cos(a)]
    inward = np.c_[-np.sin(a), np.cos(a)]
    cones = np.r_[centre + half_m * inward, centre - half_m * inward]
    colours = np.r_[np.full(n_cones, BLUE), np.full(n_cones, YELLOW)]
    if extra_xy is not None and extra_colours is not None:
        cones, colours = np.r_[cones, extra_xy], np.r_[colours, extra_colours]
    everything = cone_map(cones, colours)

    def state(t_s: float, angle: float, seen: np.ndarray | None = None) -> MapState:
        x, y = radius_m * math.sin(angle), radius_m - radius_m * math.cos(angle)
        pose = PoseEstimate(t_s, x, y, angle, speed_mps, 0.0, 0.0, np.eye(3) * 1e-4)
        cones_seen = everything if seen is None else cone_map(cones[seen], colours[seen])
        return MapState(t_s, pose, cones_seen, loop_closed=False)

    return planner, cones, colours, state


def test_a_loop_that_closes_after_the_line_counts_the_lap_already_driven() -> None:
    """While no loop is mapped (the far side mapped late, or no colours: no big orange cones)
    the lap ends where the car crosses its start line again; when the loop then closes, the
    lap driven still counts, once, and the next crossing is lap 2 (a one-lap autocross on
    QR_Nov_2022 drove two, and with the camera dead small_track was never finished)."""
    radius_m = 20.0
    planner, cones, _, state = _ring("trackdrive", radius_m, 1.75, 40, 8.0)

    def near(angle: float) -> np.ndarray:
        x, y = radius_m * math.sin(angle), radius_m - radius_m * math.cos(angle)
        return np.hypot(cones[:, 0] - x, cones[:, 1] - y) < 12.0

    planner.start_autonomous(state(0.0, 0.0, near(0.0)))
    assert planner.exploring
    # one lap and a fifth, seeing only the cones within 12 m: no loop is mapped
    angles = np.linspace(0.0, 2.4 * math.pi, 200)
    laps = []
    for k, angle in enumerate(angles[1:], 1):
        planner.plan(state(0.1 * k, float(angle), near(float(angle))), 0.1 * k)
        assert planner.exploring
        laps.append(planner.lap)
    crossed = int(np.argmax(np.asarray(laps) == 1)) + 1
    assert laps[-1] == 1 and abs(angles[crossed] - 2.0 * math.pi) < 0.1
    # now the whole lap is mapped: the loop closes a fifth of a lap past the start
    planner.plan(state(20.1, float(angles[-1])), 20.1)
    assert not planner.exploring
    assert planner.lap == 1
    # on to the next crossing: lap 2
    for k, angle in enumerate(np.linspace(2.4 * math.pi, 4.2 * math.pi, 160), 202):
        planner.plan(state(0.1 * k, float(angle)), 0.1 * k)
    assert planner.lap == 2


def test_a_loop_shorter_than_the_shortest_mapped_loop_closes_after_its_first_lap() -> None:
    """A loop mapped in the cones closes only when it is ``min_loop_length_m`` (30 m) long, so
    that a cluster of cones is not taken for the track; a 20 m circle (SmallCircle, a
    community layout) would never close, and the car explored lap after lap on the gates.
    Once a lap is counted at the start line, a loop as short as a lap may be (``lap_min_m``)
    closes."""
    radius_m = 3.2
    planner, _, _, state = _ring("trackdrive", radius_m, 1.5, 20, 3.0)
    assert 2.0 * math.pi * radius_m < planner.config.min_loop_length_m
    planner.start_autonomous(state(0.0, 0.0))
    exploring = []
    for k, angle in enumerate(np.linspace(0.0, 2.5 * math.pi, 120)[1:], 1):
        planner.plan(state(0.1 * k, float(angle)), 0.1 * k)
        exploring.append((float(angle), planner.exploring))
    assert all(still for angle, still in exploring if angle < 1.9 * math.pi)
    assert not exploring[-1][1]
    assert planner.frame is not None and planner.frame.closed
    assert planner.lap == 1


def test_an_autocross_never_closes_its_loop_and_ends_its_lap_at_the_line() -> None:
    """Autocross is one lap: a loop found in the cones is not raced (building its racing line
    takes the planner a second that drive's plans have not got), the car explores on and the
    lap ends where it crosses its start line."""
    from planner.waypoints import waypoints_from_cones

    planner, cones, colours, state = _ring("autocross", 20.0, 1.75, 40, 8.0)
    planner.start_autonomous(state(0.0, 0.0))
    laps = []
    for k, angle in enumerate(np.linspace(0.0, 2.3 * math.pi, 200)[1:], 1):
        planner.plan(state(0.1 * k, float(angle)), 0.1 * k)
        assert planner.exploring
        laps.append(planner.lap)
    # the cones do close a loop (from a quarter round the ring: a trackdrive would race on it)
    c, angle = planner.config, 0.5 * math.pi
    _, closed = waypoints_from_cones(
        cones, colours, (20.0 * math.sin(angle), 20.0 - 20.0 * math.cos(angle)), angle,
        min_pair_m=c.min_cone_pair_distance_m, max_pair_m=c.max_cone_pair_distance_m,
        max_step_m=c.waypoint_max_step_m, max_turn_rad=c.waypoint_max_turn_rad)
    assert closed
    assert laps[-1] == 1 and laps.count(0) > 150


def _laps_round_a_ring(radius_m: float, n_cones: int, line_rad: float, big_radii_m: list[float],
                       big_spread_rad: float, angles: np.ndarray, speed_mps: float) -> list[int]:
    """An autocross planner's lap count at each plan of a car driven round a ring of blue
    (inside) and yellow cones 1.5 m either side of a circle of ``radius_m`` that starts at the
    origin heading +x, at ``angles`` (rad round the ring, one plan each 0.1 s); big orange cones
    ``line_rad`` round the ring at ``big_radii_m`` from its centre, ``big_spread_rad`` apart."""
    big = [(r * math.sin(line_rad + da), radius_m - r * math.cos(line_rad + da))
           for r in big_radii_m for da in (-big_spread_rad / 2.0, big_spread_rad / 2.0)]
    planner, _, _, state = _ring("autocross", radius_m, 1.5, n_cones, speed_mps,
                                 np.asarray(big), np.full(len(big), int(ConeColour.BIG_ORANGE)))
    planner.start_autonomous(state(0.0, 0.0))
    laps = []
    for k, angle in enumerate(angles, 1):
        planner.plan(state(0.1 * k, float(angle)), 0.1 * k)
        laps.append(planner.lap)
    return laps


@pytest.mark.parametrize("sides", ["both", "outer"])
def test_the_lap_ends_at_big_orange_cones_a_quarter_lap_from_the_start(sides: str) -> None:
    """A layout may place the car a quarter of a lap before its big orange cones (SmallCircle,
    a community layout), their line not square to the car's start heading, and with only the
    outer side's seen in colour: the car passes them first as it starts (the lap's clock
    starts), and the lap ends when it passes them again, not when it passes its own start."""
    quarter = math.pi / 2.0  # the line: a quarter lap on, at (8, 8), radial
    angles = np.linspace(0.0, 3.0 * math.pi, 300)[1:]
    laps = _laps_round_a_ring(8.0, 40, quarter, [6.5, 9.5] if sides == "both" else [9.5],
                              0.06, angles, 4.0)
    first = int(np.argmax(np.asarray(laps) == 1))
    assert laps[-1] == 1
    assert abs(angles[first] - (quarter + 2.0 * math.pi)) < 0.1


@pytest.mark.parametrize("phase", [0.0, 0.2, 0.4, 0.6, 0.8])
def test_a_lap_round_a_tight_circle_ends_abreast_of_one_sides_big_cones(phase: float) -> None:
    """Round a 3 m circle (SmallCircle, a community layout) at 3.5 m/s, planned at 10 Hz, the
    car turns 0.12 rad between plans; with big orange cones seen on the outer side only, the
    lap ends where the car passes them abreast, whichever moment of a plan that falls on (a
    line square to the car's own step turns with it and could jump over the car)."""
    step_rad, line = 0.12, 1.9  # the line: 1.9 rad round the circle from the start
    angles = np.arange(phase * step_rad, 3.5 * math.pi, step_rad)
    laps = _laps_round_a_ring(3.0, 24, line, [4.5], 0.1, angles, 3.5)
    first = int(np.argmax(np.asarray(laps) == 1))
    assert laps[-1] == 1
    # counted at the first plan past the point, judged along the last step (half a step behind)
    assert 0.0 <= angles[first] - (line + 2.0 * math.pi) <= 1.5 * step_rad
