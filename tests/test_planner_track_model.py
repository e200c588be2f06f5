"""The track model from cones, the racing line inside it, and the checks built on them."""

from __future__ import annotations

import math

import numpy as np
import pytest

from common.car import CarConfig
from common.errors import TrackError
from common.messages import ConeColour
from planner.racing_line import body_margins_m, line_lap_time_s, racing_line
from planner.speed_profile import SpeedLimits, steering_lock_cap, steering_rate_speed_limit_mps
from planner.track_model import menger_curvature, self_intersects, track_from_cones
from simulator.tracks import load_track

BLUE, YELLOW = int(ConeColour.BLUE), int(ConeColour.YELLOW)


def _cones_of(name: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    track = load_track(name)
    return track.cones_xy_m, track.colours, track.centreline_xy_m


def _circle_track(radius_m: float, half_width_m: float, spacing_m: float = 2.0):
    n = int(2 * math.pi * radius_m / spacing_m)
    a = np.linspace(0.0, 2 * math.pi, n, endpoint=False)
    unit = np.c_[np.cos(a), np.sin(a)]
    left = (radius_m - half_width_m) * unit  # counter-clockwise: the inside is on the left
    right = (radius_m + half_width_m) * unit
    cones = np.r_[left, right]
    colours = np.r_[np.full(n, BLUE), np.full(n, YELLOW)]
    return cones, colours, radius_m * unit


def test_track_model_of_a_circle_has_its_centre_and_widths() -> None:
    """Cones every 2 m on circles 1.75 m either side of R = 15 m: the model's centre is on the
    middle circle and each width is 1.75 m, short of it only by the chord sag between cones
    (R (1 - cos(theta / 2)) with theta = 2 / R: under 0.04 m)."""
    cones, colours, guide = _circle_track(15.0, 1.75)
    model = track_from_cones(cones, colours, guide * 1.05, True)  # a guide off the middle
    radius = np.hypot(*model.centre_xy_m.T)
    assert np.max(np.abs(radius - 15.0)) < 0.05
    assert np.all(np.abs(model.left_width_m - 1.75) < 0.06)
    assert np.all(np.abs(model.right_width_m - 1.75) < 0.06)
    assert np.allclose(np.abs(model.curvature_1pm), 1.0 / 15.0, atol=0.004)


def test_track_model_with_one_side_unmapped_keeps_the_nominal_width() -> None:
    cones, colours, guide = _circle_track(15.0, 1.75)
    blue = colours == BLUE
    model = track_from_cones(cones[blue], colours[blue], guide, True, nominal_width_m=3.5)
    # the mapped side is where it is; the other is a nominal track width away
    assert np.all(np.abs(model.left_width_m - 1.75) < 0.1)
    assert np.all(np.abs(model.left_width_m + model.right_width_m - 3.5) < 0.1)


def test_track_model_without_cones_is_refused() -> None:
    _, _, guide = _circle_track(15.0, 1.75)
    with pytest.raises(TrackError):
        track_from_cones(np.zeros((0, 2)), np.zeros(0), guide, True)


def test_free_interval_keeps_each_margin_and_stays_on_its_own_stretch() -> None:
    """hard:hairpins: straights 6 m apart, 3 m wide. The room of each sample is on its own
    straight, never on the neighbouring one across the infield."""
    cones, colours, guide = _cones_of("hard:hairpins")
    model = track_from_cones(cones, colours, guide, True)
    lo, hi = model.free_interval(0.9, 0.9)
    assert np.all(lo <= hi)
    # 3 m wide: on the straights the free band of a 0.9 m margin each side is 1.2 m, in the
    # middle (cone spacing makes the boundary wave by a few centimetres)
    straight = np.abs(model.curvature_1pm) < 0.01
    assert np.all(np.abs(hi[straight] - lo[straight] - 1.2) < 0.15)
    assert np.all(np.abs(lo) <= 1.5) and np.all(np.abs(hi) <= 1.5)
    # no room anywhere for margins wider than the track: the best point is still inside it
    lo, hi = model.free_interval(2.0, 2.0)
    assert np.allclose(lo, hi) and np.all(np.abs(lo) < 0.5)


def test_body_margins_grow_on_the_outside_of_a_bend() -> None:
    """On a 3 m radius bend the front outer corner of a 1.4 m wide car with its front 2.25 m
    ahead of the rear axle sweeps sqrt(3.7^2 + 2.25^2) - 3.7 = 0.63 m beyond its half width."""
    kappa = np.r_[np.zeros(10), np.full(10, 1.0 / 3.0), np.zeros(10)]
    left, right = body_margins_m(kappa, 0.7, 2.25, 0.0)
    expected = 0.7 + math.hypot(3.7, 2.25) - 3.7
    assert right[15] == pytest.approx(expected, abs=1e-9)  # turning left: the right is outside
    assert left[15] == pytest.approx(0.7)
    assert left[0] == right[0] == pytest.approx(0.7)


@pytest.mark.parametrize("name", ["hard:chicanes", "gen:3"])
def test_racing_line_stays_in_its_bounds_and_is_faster_than_the_centreline(name: str) -> None:
    cones, colours, guide = _cones_of(name)
    model = track_from_cones(cones, colours, guide, True)
    car = CarConfig()
    limits = SpeedLimits.from_car(car, 0.7, 25.0, lateral_factor=0.6)
    front = car.length_m - car.rear_overhang_m
    line, offsets = racing_line(model, half_width_m=car.width_m / 2, front_m=front,
                                clearance_m=0.55, limits=limits)
    left, right = body_margins_m(model.curvature_1pm, car.width_m / 2, front, 0.55)
    lo, hi = model.free_interval(left, right)
    assert np.all(offsets >= lo - 1e-6) and np.all(offsets <= hi + 1e-6)
    assert np.allclose(line, model.centre_xy_m + offsets[:, None] * model.normals)
    t_line = line_lap_time_s(line, True, limits)
    t_centre = line_lap_time_s(model.centre_xy_m, True, limits)
    assert t_line < t_centre
    # the chicane is straightened: the line bends less than the centreline does
    assert np.max(np.abs(menger_curvature(line, True))) < np.max(np.abs(model.curvature_1pm))


def _oval(arc_cones: int, straight_m: float = 47.0, radius_m: float = 7.5,
          half_width_m: float = 1.5, spacing_m: float = 5.0):
    """EPFL's 21_05_2023 layout's shape: two straights joined by half circles of ``arc_cones``
    cones a side, a 3 m lane; cones (N, 2), colours (N,) and the centre line."""
    rows = []
    for r in (radius_m - half_width_m, radius_m + half_width_m, radius_m):
        n = int(round(straight_m / spacing_m))
        arc = np.linspace(-math.pi / 2, math.pi / 2, arc_cones, endpoint=False)
        rows.append(np.r_[
            np.c_[np.linspace(0.0, straight_m, n, endpoint=False), np.full(n, -r)],
            np.c_[straight_m + r * np.cos(arc), r * np.sin(arc)],
            np.c_[np.linspace(straight_m, 0.0, n, endpoint=False), np.full(n, r)],
            np.c_[-r * np.cos(arc), -r * np.sin(arc)]])
    inner, outer, centre = rows
    return (np.r_[inner, outer], np.r_[np.full(len(inner), BLUE), np.full(len(outer), YELLOW)],
            centre)


def test_a_racing_line_slower_than_the_centreline_gives_way_to_it() -> None:
    """A 3 m lane round half circles of six cones a side: the car's body and margins leave a
    room a few centimetres wide that zigzags with the chords between the cones, and the line
    of least curvature inside it is 1.2 s slower than the centre line (kinks of 0.39 1/m on
    EPFL's layout: its mapped laps were 1.53x the friction limit, 1.16x on the centre line).
    The centre line is then the line."""
    cones, colours, guide = _oval(arc_cones=6)
    model = track_from_cones(cones, colours, guide, True)
    car = CarConfig()
    limits = SpeedLimits.from_car(car, 0.7, 18.0, lateral_factor=0.6)
    line, offsets = racing_line(model, half_width_m=car.width_m / 2,
                                front_m=car.length_m - car.rear_overhang_m, clearance_m=0.55,
                                limits=limits)
    t_centre = line_lap_time_s(model.centre_xy_m, True, limits)
    assert line_lap_time_s(line, True, limits) <= t_centre
    assert np.all(offsets == 0.0)
    # with room enough (eight cones a side round the half circles) the line is taken
    model = track_from_cones(*_oval(arc_cones=8), True)
    line, offsets = racing_line(model, half_width_m=car.width_m / 2,
                                front_m=car.length_m - car.rear_overhang_m, clearance_m=0.55,
                                limits=limits)
    assert np.any(offsets != 0.0)
    assert line_lap_time_s(line, True, limits) < line_lap_time_s(model.centre_xy_m, True, limits)


def _tight_circle():
    """SmallCircle's size (a community layout): cones 1.5 m either side of a 3.2 m circle,
    0.7 m apart; the car's body and margins (1.25 m inside, 1.85 m outside) need 3.1 m."""
    car = CarConfig()
    model = track_from_cones(*_circle_track(3.2, 1.5, 0.7), True)
    front = car.length_m - car.rear_overhang_m
    return car, model, front


def test_where_the_track_is_too_narrow_the_line_may_use_a_band_about_the_most_room() -> None:
    """Pinned to the offset with the most room, a line follows every wobble of the boundaries
    by a grid step; with a band it may lie anywhere within 0.1 m of room of the most, an
    interval 0.2 m wide (the room falls 1 m per metre either side of the best)."""
    car, model, front = _tight_circle()
    left, right = body_margins_m(model.curvature_1pm, car.width_m / 2, front, 0.55)
    lo, hi, pinched = model.free_interval_pinched(left, right)
    assert pinched.all() and np.allclose(lo, hi)
    lo_b, hi_b, _ = model.free_interval_pinched(left, right, pinch_band_m=0.1)
    assert np.allclose(hi_b - lo_b, 0.2, atol=0.051)
    assert np.all((lo_b <= lo + 1e-9) & (lo <= hi_b + 1e-9))


def test_the_racing_line_round_a_tight_circle_stays_within_the_steering_lock() -> None:
    """Round a circle a point mass is fastest on the inside (a lap takes 2 pi sqrt(R / a)),
    and the line of a planner that knows only friction takes it, at 2.8 m, a curvature the
    car's steering cannot hold (L 1.53 m, lock 0.52 rad: 95 % of it holds 0.352 1/m). With the
    lock's speed limit the line keeps to the outside of the band, within the lock."""
    car, model, front = _tight_circle()
    limits = SpeedLimits.from_car(car, 0.7, 25.0, lateral_factor=0.6)
    lock_kappa = math.tan(0.95 * car.max_steer_rad) / car.wheelbase_m
    kwargs = dict(half_width_m=car.width_m / 2, front_m=front, clearance_m=0.55, limits=limits)
    inside, _ = racing_line(model, **kwargs)
    assert np.max(np.abs(menger_curvature(inside, True))) > lock_kappa
    cap = steering_lock_cap(car, 0.95, 0.004, 2.0)
    line, _ = racing_line(model, **kwargs, speed_cap=cap)
    assert np.max(np.abs(menger_curvature(line, True))) <= lock_kappa
    assert np.min(np.hypot(*line.T)) > np.max(np.hypot(*inside.T))
    assert line_lap_time_s(line, True, limits, cap) < line_lap_time_s(inside, True, limits, cap)


def test_self_intersection_tells_a_figure_of_eight_from_a_loop() -> None:
    a = np.linspace(0.0, 2 * math.pi, 200, endpoint=False)
    circle = np.c_[np.cos(a), np.sin(a)] * 10.0
    eight = np.c_[10.0 * np.sin(a), 10.0 * np.sin(a) * np.cos(a)]
    assert not self_intersects(circle, True)
    assert self_intersects(eight, True)


def test_steering_rate_limits_the_speed_where_the_curvature_changes() -> None:
    """Curvature ramping by 0.1 1/m per metre: at speed v the wheel turns at v 0.1 L rad/s, so
    with L = 1.53 m and 1.5 rad/s the limit is 1.5 / 0.153 = 9.8 m/s (no understeer); a
    constant curvature sets no limit."""
    kappa = np.r_[np.zeros(20), np.linspace(0.0, 0.3, 31), np.full(20, 0.3)]
    v = steering_rate_speed_limit_mps(kappa, 0.1, 1.53, 1.5, 0.0, closed=False)
    ramp = v[25:45]
    assert np.allclose(ramp, 1.5 / (0.1 * 1.53), rtol=0.02)
    assert np.all(v[:10] > 100.0) and np.all(v[-8:] > 100.0)
    with_understeer = steering_rate_speed_limit_mps(kappa, 0.1, 1.53, 1.5, 0.004, closed=False)
    assert np.all(with_understeer[25:45] < ramp)


def test_search_widens_when_every_configured_offset_is_blocked() -> None:
    """A wall of cones across the straight from -2.0 m to +1.0 m: every configured offset
    (within +-1.5 m) hits it (the car's half width 0.7 m, a cone 0.15 m), a wider one passes it
    on the left. The generator finds it and
    counts the nominal family's rejections by the check that failed."""
    from planner.baseframe import SplineBaseframe
    from planner.config import PlannerConfig
    from planner.manoeuvres import ManoeuvreGenerator

    frame = SplineBaseframe(np.c_[np.linspace(0.0, 80.0, 81), np.zeros(81)], False)
    wall = np.c_[np.full(14, 12.0), np.linspace(-2.0, 1.0, 14)]
    generator = ManoeuvreGenerator(PlannerConfig(), CarConfig())
    cands, best = generator.generate(frame, 0.0, 0.0, 0.0, 3.0, wall, None)
    assert best >= 0
    chosen = cands[best]
    assert chosen.feasible and chosen.offset_m > 1.85
    assert generator.rejections["nominal: clearance"] == generator.config.offsets_count
    # nothing to pass by, within the car's commitment (the 6 m horizon at 3 m/s): every family
    # is tried, none is feasible, each rejection is counted
    blocked = ManoeuvreGenerator(PlannerConfig(), CarConfig())
    closed_wall = np.c_[np.full(40, 5.0), np.linspace(-6.0, 6.0, 40)]
    assert blocked.commit_m(blocked.horizon_m(3.0), 3.0) == pytest.approx(6.0)
    _, best = blocked.generate(frame, 0.0, 0.0, 0.0, 3.0, closed_wall, None)
    assert best == -1
    assert {k.split(":")[0] for k in blocked.rejections} == {"nominal", "wide", "short",
                                                              "shortest", "crawl",
                                                              "crawl short"}


def test_a_corridor_with_only_a_cones_radius_to_spare_is_crawled() -> None:
    """Cones 0.17 m from the car's body on both sides all along a straight: more than a cone's
    radius (0.15 m), less than the full margin (0.2 m). Every family at the full margin is
    refused; the crawl, at the cone's radius and walking pace, drives on."""
    from planner.baseframe import SplineBaseframe
    from planner.config import PlannerConfig
    from planner.manoeuvres import ManoeuvreGenerator

    config = PlannerConfig()
    generator = ManoeuvreGenerator(config, CarConfig())
    room = generator.circle_radius_m + 0.17
    frame = SplineBaseframe(np.c_[np.linspace(0.0, 80.0, 81), np.zeros(81)], False)
    x = np.arange(-2.0, 40.0, 0.5)
    walls = np.r_[np.c_[x, np.full(len(x), room)], np.c_[x, np.full(len(x), -room)]]
    cands, best = generator.generate(frame, 0.0, 0.0, 0.0, 3.0, walls, None)
    assert best >= 0
    assert cands[best].speed_cap_mps == config.crawl_speed_mps
    assert abs(cands[best].offset_m) < 0.01
    assert generator.rejections["shortest: clearance"] > 0
    # with room for the full margin the configured offsets do
    wider = ManoeuvreGenerator(config, CarConfig())
    walls[:, 1] *= (room + 0.05) / room
    cands, best = wider.generate(frame, 0.0, 0.0, 0.0, 3.0, walls, None)
    assert best >= 0 and cands[best].speed_cap_mps == math.inf


def test_at_speed_a_lane_needs_more_room_or_is_taken_slower() -> None:
    """Exploring, cones 0.28 m from the car's body on both sides all along a straight: at
    6 m/s the full margin (0.2 m) fits and the configured offsets drive on uncapped; at 13 m/s
    the margin is 0.35 m (``cone_clearance_per_mps`` 0.03 above 8 m/s), which does not fit,
    and the short fallback, driven at its 4 m/s and so at the plain margin, takes the lane."""
    from planner.baseframe import SplineBaseframe
    from planner.config import PlannerConfig
    from planner.manoeuvres import ManoeuvreGenerator

    config = PlannerConfig()
    generator = ManoeuvreGenerator(config, CarConfig())
    assert generator.full_margin_m(6.0) == config.cone_clearance_m
    assert generator.full_margin_m(13.0) == pytest.approx(0.35)
    assert generator.full_margin_m(-13.0) == pytest.approx(0.35)
    room = generator.circle_radius_m + 0.28
    frame = SplineBaseframe(np.c_[np.linspace(0.0, 120.0, 121), np.zeros(121)], False)
    x = np.arange(-2.0, 60.0, 0.5)
    walls = np.r_[np.c_[x, np.full(len(x), room)], np.c_[x, np.full(len(x), -room)]]
    cands, best = generator.generate(frame, 0.0, 0.0, 0.0, 6.0, walls, None, speed_margin=True)
    assert best >= 0 and cands[best].speed_cap_mps == math.inf
    fast = ManoeuvreGenerator(config, CarConfig())
    cands, best = fast.generate(frame, 0.0, 0.0, 0.0, 13.0, walls, None, speed_margin=True)
    assert best >= 0
    assert cands[best].speed_cap_mps == config.fallback_speed_mps
    assert fast.rejections["nominal: clearance"] == config.offsets_count
    assert cands[best].clearance_m == pytest.approx(0.28, abs=0.01)
    # on a mapped lap (no speed margin) the lane is taken at speed as before
    cands, best = generator.generate(frame, 0.0, 0.0, 0.0, 13.0, walls, None)
    assert best >= 0 and cands[best].speed_cap_mps == math.inf


@pytest.mark.parametrize("closed", [True, False])
def test_racing_line_gradient_is_the_sparse_jacobians_bit_for_bit(closed: bool) -> None:
    from planner.racing_line import _CurvatureGradient, _jacobian, _menger_xy

    rng = np.random.default_rng(3)
    n = 101
    a = np.linspace(0.0, 2 * math.pi, n, endpoint=False)
    centre = np.c_[30 * np.cos(a), 20 * np.sin(a)] + rng.normal(0.0, 0.5, (n, 2))
    centre[5] = centre[4]  # a repeated point
    normals = rng.standard_normal((n, 2))
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    alpha = rng.normal(0.0, 1.0, n)
    fast = _CurvatureGradient(centre, normals, closed)
    kappa = menger_curvature(centre + alpha[:, None] * normals, closed)
    assert _menger_xy(*fast.line(alpha), closed).tobytes() == kappa.tobytes()
    sparse = np.asarray(_jacobian(centre, normals, alpha, closed).tocsr().T @ (2.0 * kappa))
    assert fast.gradient(alpha, kappa).tobytes() == sparse.tobytes()
