"""The unseen track's speed limit (planner/exploration_speed.py, issue 45): the car can always
stop within the part of the track it has seen, and nothing but that, the friction circle and the
steering sets the pace."""

from __future__ import annotations

import numpy as np
import pytest

from planner.config import PlannerConfig
from planner.exploration_speed import (
    exploring_curvature,
    exploring_end_speed_mps,
    exploring_lead_m,
    seen_track_speed_mps,
    speed_curvature,
    speed_limit_along_mps,
    stop_room_m,
)

SPEEDS = np.arange(0.0, 40.0, 0.05)
# the supervisor's rule as Main hands it in: 0.3 s late, 0.2 s reaction, 0.2 m, 6 m/s^2
ROOM = stop_room_m(SPEEDS, 0.3, 0.2, 0.2, 6.0)


def test_the_limit_leaves_room_to_stop_everywhere() -> None:
    remaining = np.linspace(0.0, 60.0, 601)
    v = seen_track_speed_mps(remaining, ROOM, SPEEDS)
    assert np.all(stop_room_m(v, 0.3, 0.2, 0.2, 6.0) <= np.maximum(remaining, 0.2) + 1e-6)
    # and it is the highest such speed (within the table's step)
    assert np.all(stop_room_m(v + 0.06, 0.3, 0.2, 0.2, 6.0)[remaining > 0.3]
                  > remaining[remaining > 0.3])
    assert v[0] == 0.0
    assert np.all(np.diff(v) >= 0.0)


def test_top_speed_caps_and_no_table_means_no_limit_but_it() -> None:
    v = seen_track_speed_mps(np.array([5.0, 500.0]), ROOM, SPEEDS, top_speed_mps=12.0)
    assert v[1] == 12.0 and v[0] < 12.0
    free = seen_track_speed_mps(np.array([1.0, 50.0]), np.zeros(0), np.zeros(0), 9.0)
    assert np.all(free == 9.0)


@pytest.mark.parametrize("car_s_m", [0.0, 1.5, 4.0])
def test_along_the_frame_the_car_never_asks_more_than_it_may_drive_where_it_is(
        car_s_m: float) -> None:
    s = np.arange(0.0, 12.0 + 1e-9, 0.25)
    length = float(s[-1])
    v = speed_limit_along_mps(s, length, ROOM, SPEEDS, 14.0, car_s_m, lead_s=0.75,
                              max_lead_m=8.0)
    at_car = seen_track_speed_mps(np.array([length - car_s_m]), ROOM, SPEEDS)[0]
    assert np.all(v <= at_car + 1e-9)
    # just ahead of the car (where the controller reads its speed) the limit is the car's own,
    # not an end of the track a preview nearer
    ahead = (s >= car_s_m) & (s <= car_s_m + 2.0)
    assert np.allclose(v[ahead], at_car)
    # without the lead it would ask less there: the car would brake all the time
    plain = speed_limit_along_mps(s, length, ROOM, SPEEDS, 14.0, car_s_m)
    assert np.all(plain[ahead][1:] < at_car)
    # further on, the limit falls to the end: each point's is the invariant of a point one
    # lead (the controller's reach at the car's own limit) nearer the car
    lead = exploring_lead_m(float(at_car), 0.75, 8.0)
    assert 0.0 < lead <= 8.0
    beyond = s > car_s_m + lead
    assert np.all(np.diff(v[beyond]) <= 1e-9)
    assert np.allclose(v[beyond], seen_track_speed_mps(length - s[beyond], ROOM, SPEEDS,
                                                       lead_m=lead))
    assert v[-1] < at_car
    # the car itself, at the end of the track seen, may not move
    assert speed_limit_along_mps(s, length, ROOM, SPEEDS, 14.0, length, 0.75, 8.0)[-1] == 0.0


def test_the_profile_ends_at_a_standstill_one_lead_beyond_the_end() -> None:
    """The frame's end speed: a stop at the profile's braking within the lead, the very shift
    of the invariant; no lead, a standstill at the end."""
    assert exploring_end_speed_mps(0.0, 8.4) == 0.0
    v = exploring_end_speed_mps(6.0, 8.4)
    assert v * v / (2.0 * 8.4) == pytest.approx(6.0)
    assert exploring_lead_m(12.0, 0.75, 8.0) == 8.0 and exploring_lead_m(4.0, 0.75, 8.0) == 3.0


def test_speed_curvature_removes_kinks_not_bends() -> None:
    step = 0.25
    s = np.arange(0.0, 60.0, step)
    # a 10 m bend of radius 3 m (the rules' tightest hairpin) then one of 8 m the other way
    bend = np.where((s > 20.0) & (s < 30.0), 1.0 / 3.0, 0.0)
    bend = np.where((s >= 30.0) & (s < 40.0), -1.0 / 8.0, bend)
    kinked = bend.copy()
    kinked[(s > 10.0) & (s < 10.6)] = 0.4  # a kink of a path through cones seen partly
    kinked[(s > 45.0) & (s < 45.6)] = -0.3
    out = speed_curvature(kinked, step, 1.5)
    assert np.allclose(out, bend)  # the bends whole, their change of direction too
    assert np.array_equal(speed_curvature(kinked, step, 0.0), kinked)


def test_exploring_curvature_starts_from_the_track_beyond_the_car() -> None:
    config = PlannerConfig(exploration_start_m=1.0, exploration_curvature_window_m=0.0,
                           exploration_rate_sigma_m=0.0)
    kappa = np.r_[np.full(4, 0.5), np.full(20, 0.05)]
    speed, rate = exploring_curvature(kappa, 0.25, config)
    assert np.allclose(speed, 0.05) and np.allclose(rate, 0.05)
    assert kappa[0] == 0.5  # the frame's own curvature is left as it is


def test_the_steering_rate_reads_a_smoothed_curvature_the_friction_circle_the_peak() -> None:
    config = PlannerConfig(exploration_start_m=0.0, exploration_curvature_window_m=0.0,
                           exploration_rate_sigma_m=1.5)
    s = np.arange(0.0, 40.0, 0.25)
    kappa = np.where((s > 20.0) & (s < 30.0), 1.0 / 3.0, 0.0)
    kappa[(s > 10.0) & (s < 10.5)] = 0.3  # a kink
    speed, rate = exploring_curvature(kappa, 0.25, config)
    assert np.array_equal(speed, kappa)  # the bend's and the kink's curvature: both kept
    slope = np.abs(np.gradient(rate, 0.25))
    assert slope[(s > 8.0) & (s < 13.0)].max() < 0.25 * np.abs(np.gradient(kappa, 0.25)).max()


@pytest.mark.parametrize("colour", [True, False])
def test_exploring_a_lap_the_car_can_always_stop_within_the_track_it_has_seen(
        colour: bool) -> None:
    """The invariant in the planner itself, over the growing cone views of a lap of the
    built-in track (``bench plan_local``'s, the cones mapped 15 m ahead in the camera's field
    of view): wherever the car is, the speed the profile asks of it, from the car to as far
    ahead as the controller reads it, leaves the room for the late cover and the
    supervisor's stop before the end of the track seen; and the pace is not a constant."""
    from bench.bench_plan_local import cone_views, map_state
    from common.messages import ConeColour
    from controller.safety import late_stop_distance_m
    from orchestrator.config import AppConfig
    from planner.path_planner import PathPlanner
    from simulator.tracks import load_track

    config = AppConfig()
    assert config.planner.exploration_speed_mps >= 12.0  # the invariant binds, not the cap
    safety = config.controller.safety
    late_s = config.planner.exploration_late_cover_s
    track = load_track("default")
    views = cone_views(track, step_m=3.0, range_m=15.0, limit=60)
    colours = np.asarray(track.colours, np.int64)
    if not colour:
        colours = np.full_like(colours, int(ConeColour.UNKNOWN))
    planner = PathPlanner(config.planner, config.car,
                          stop_distance_m=lambda v: late_stop_distance_m(v, safety))
    planner.start_autonomous(map_state(views[0], colours))
    asked = []
    rooms = []
    for view in views:
        state = map_state(view, colours)
        if not planner.explore(state) or not planner.exploring:
            continue
        frame = planner.frame
        assert frame is not None
        s_car = float(frame.project(view.x_m, view.y_m)[0])
        room = frame.length_m - s_car
        rooms.append(room)
        assert planner.views_ahead_m[-1] == pytest.approx(room, abs=1e-6)
        lead = planner.config.exploration_speed_lead_max_m
        s = np.linspace(s_car, min(s_car + lead, frame.length_m), 9)
        v = planner.speed_at(s)
        need = np.array([x * late_s + late_stop_distance_m(float(x), safety) for x in v])
        assert np.all(need[v > 0.0] <= room + 0.05), (view.t_s, room, v)
        asked.append(float(v[0]))
    assert len(asked) > 30
    assert max(asked) > 9.0  # past the constant cap it had (8 m/s)
    # the run's view: the median seen track ahead, and the pace it allows on a straight
    explored = planner.explored_view()
    assert explored is not None
    view_m, speed_mps = explored
    assert min(rooms) <= view_m <= max(rooms)
    assert speed_mps * late_s + late_stop_distance_m(speed_mps, safety) <= view_m + 1e-6


def _lane(width_m: float, pinch_m: float | None = None, length_m: float = 40.0
          ) -> np.ndarray:
    """Cones along a straight lane along +x, every 3 m on both sides ``width_m`` apart; from
    x = 18 to 24 m ``pinch_m`` apart (when given)."""
    x = np.arange(0.0, length_m + 0.1, 3.0)
    half = np.full(len(x), width_m / 2.0)
    if pinch_m is not None:
        half[(x >= 18.0) & (x <= 24.0)] = pinch_m / 2.0
    return np.vstack([np.c_[x, half], np.c_[x, -half]])


def _generator():  # type: ignore[no-untyped-def]
    from common.car import CarConfig
    from planner.manoeuvres import ManoeuvreGenerator

    return ManoeuvreGenerator(PlannerConfig(), CarConfig())


def test_the_room_about_the_path_is_what_the_manoeuvres_check_leaves() -> None:
    """Twice what the path may move to either side before the manoeuvres' circles come
    within their full margin of a cone: a 3.5 m lane leaves 2 x (1.75 - required), a 2.5 m
    one 2 x (1.25 - required); a path off the middle the lesser side; on a cone, none."""
    from planner.exploration_speed import passage_room_m

    gen = _generator()
    req = gen.required_m
    x = np.arange(3.0, 37.0, 0.5)
    on_mid = np.c_[x, np.zeros(len(x))]
    heading = np.zeros(len(x))
    wide = passage_room_m(on_mid, heading, _lane(3.5), gen.circle_offsets_m, req, 2.5)
    # (between two cones of a side the circles reach a little less far: up to 0.1 m more)
    assert np.all((wide >= 2.0 * (1.75 - req) - 1e-6) & (wide <= 2.0 * (1.75 - req) + 0.1))
    pinched = passage_room_m(on_mid, heading, _lane(3.5, 2.5), gen.circle_offsets_m, req, 2.5)
    in_pinch = (x >= 19.0) & (x <= 22.0)
    assert np.all(np.abs(pinched[in_pinch] - 2.0 * (1.25 - req)) <= 0.1)
    assert np.allclose(pinched[x <= 12.0], wide[x <= 12.0])
    aside = passage_room_m(on_mid + [0.0, 0.4], heading, _lane(3.5), gen.circle_offsets_m,
                           req, 2.5)
    assert np.all(np.abs(aside - 2.0 * (1.75 - 0.4 - req)) <= 0.1)
    on_cone = passage_room_m(np.array([[3.0, 1.75]]), np.zeros(1), _lane(3.5),
                             gen.circle_offsets_m, req, 2.5)
    assert on_cone[0] == 0.0
    free = passage_room_m(on_mid, heading, np.zeros((0, 2)), gen.circle_offsets_m, req, 2.5)
    assert np.all(free == 5.0)


def test_a_narrow_passage_is_driven_at_its_speed_and_a_lane_as_wide_as_the_rules_not() -> None:
    """Along an exploring frame, the passage 2.5 m between cone centres is limited to
    ``exploration_narrow_speed_mps`` (with the body's length, a little before and after it);
    the 3.5 m lane and the rules' narrowest track (3 m) are not limited."""
    from planner.baseframe import SplineBaseframe
    from planner.exploration_speed import narrow_passage_limit_mps

    config = PlannerConfig()
    gen = _generator()
    x = np.arange(0.0, 40.5, 1.0)
    frame = SplineBaseframe(np.c_[x, np.zeros(len(x))], False, step_m=0.25)
    s = frame.s_m
    v = narrow_passage_limit_mps(frame, _lane(3.5, 2.5), gen, config)
    assert np.all(v[(s >= 19.0) & (s <= 22.0)] == config.exploration_narrow_speed_mps)
    assert np.all(np.isinf(v[(s > 3.0) & (s < 14.0)]))
    for width in (3.5, 3.0):
        assert np.all(np.isinf(narrow_passage_limit_mps(frame, _lane(width), gen, config)))
    off = PlannerConfig(exploration_narrow_room_m=0.0)
    assert np.all(np.isinf(narrow_passage_limit_mps(frame, _lane(3.5, 2.5), gen, off)))
    assert np.all(np.isinf(narrow_passage_limit_mps(frame, None, gen, config)))


def test_the_late_cover_spans_every_plan_the_supervisor_lets_the_car_follow_at_speed() -> None:
    """A plan up to the supervisor's ``plan_timeout_s`` old is followed at speed; an older one
    is late, and the supervisor then holds the car to a speed whose manoeuvre covers a stop.
    The invariant's cover must reach that far, or a plan just short of late would not."""
    from orchestrator.config import AppConfig

    config = AppConfig()
    assert (config.planner.exploration_late_cover_s
            >= config.controller.safety.plan_timeout_s > 0.0)


@pytest.mark.parametrize("tentative", [False, True])
def test_the_planner_slows_a_narrow_passage_whether_or_not_the_camera_adds_cones(
        tentative: bool) -> None:
    """The exploring planner's own profile through the pinch of a lane of landmarks is held to
    ``exploration_narrow_speed_mps``, with the LiDAR's landmarks alone as with a camera cone
    (id < 0) in the map too: a limit that came and went with the camera's tentative cones made
    the speed jump between plans (EUFS small_track_2, seed 3: 7.4 m/s into its 2.5 m bend, a
    fallback at 4 m/s, 0.008 m from a cone)."""
    from common.messages import ConeColour, ConeMap, MapState, PoseEstimate
    from orchestrator.config import AppConfig
    from planner.path_planner import PathPlanner

    config = AppConfig()
    lane = _lane(3.5, 2.5, length_m=30.0)
    n = len(lane)
    half = n // 2
    colours = np.r_[np.full(half, int(ConeColour.BLUE)), np.full(n - half, int(ConeColour.YELLOW))]
    ids = np.arange(n, dtype=np.int64)
    if tentative:  # one camera cone beyond the lane's end, on its left side
        lane = np.vstack([lane, [33.0, 1.75]])
        colours = np.append(colours, int(ConeColour.BLUE))
        ids = np.append(ids, -1)
    m = len(lane)
    cones = ConeMap(xy_m=lane, covariance=np.tile(np.eye(2) * 0.01, (m, 1, 1)), colour=colours,
                    size=np.ones(m, np.int64), confidence=np.ones(m), ids=ids)
    pose = PoseEstimate(0.0, 4.0, 0.0, 0.0, 5.0, 0.0, 0.0, np.eye(3) * 1e-4)
    planner = PathPlanner(config.planner, config.car)
    state = MapState(0.0, pose, cones, loop_closed=False)
    planner.start_autonomous(state)
    assert planner.explore(state) and planner.exploring
    frame = planner.frame
    assert frame is not None
    s_pinch = np.array([frame.project(x, 0.0)[0] for x in np.arange(19.0, 23.5, 0.5)])
    assert np.all(planner.speed_at(s_pinch) <= config.planner.exploration_narrow_speed_mps + 1e-9)
    s_open = np.array([frame.project(x, 0.0)[0] for x in (8.0, 9.0, 10.0)])
    assert np.all(planner.speed_at(s_open) > config.planner.exploration_narrow_speed_mps)


def test_the_lateral_factor_grows_with_the_room_from_the_rules_narrowest_lane() -> None:
    from planner.exploration_speed import room_lateral_factor

    config = PlannerConfig()
    tight, wide = config.exploration_tight_room_m, config.exploration_wide_room_m
    factor = room_lateral_factor(np.array([0.0, tight, 0.5 * (tight + wide), wide, 5.0]), config)
    low, high = config.lateral_safety_factor, config.exploration_lateral_safety_factor
    assert high > low
    assert np.allclose(factor, [low, low, 0.5 * (low + high), high, high])
    # a lateral_safety_factor tuned above the room's holds everywhere
    tuned = PlannerConfig(lateral_safety_factor=0.8)
    assert np.allclose(room_lateral_factor(np.array([0.0, tight, wide, 5.0]), tuned), 0.8)


def _bend_lane(width_m: float, radius_m: float = 10.0) -> tuple[np.ndarray, np.ndarray]:
    """Cones (N, 2) and colours (N,) of a lane ``width_m`` wide: 6 m straight along +x from
    the origin, a left bend of ``radius_m`` through 90 degrees, 20 m straight along +y; a
    cone every 2.5 m of its middle on either side (blue left, yellow right)."""
    from common.messages import ConeColour

    s = np.arange(0.0, 6.0 + 0.5 * np.pi * radius_m + 20.0, 2.5)
    arc = np.clip(s - 6.0, 0.0, 0.5 * np.pi * radius_m) / radius_m  # heading (rad)
    x = np.where(s < 6.0, s, 6.0 + radius_m * np.sin(arc))
    y = np.where(s < 6.0, 0.0, radius_m * (1.0 - np.cos(arc)))
    beyond = s - 6.0 - 0.5 * np.pi * radius_m
    x = np.where(beyond > 0.0, 6.0 + radius_m, x)
    y = np.where(beyond > 0.0, radius_m + beyond, y)
    normal = np.c_[-np.sin(arc), np.cos(arc)]
    middle = np.c_[x, y]
    cones = np.vstack([middle + 0.5 * width_m * normal, middle - 0.5 * width_m * normal])
    colours = np.r_[np.full(len(s), int(ConeColour.BLUE)), np.full(len(s), int(ConeColour.YELLOW))]
    return cones, colours


def _exploring_bend_speed_mps(width_m: float, lateral_factor: float) -> float:
    """The exploring planner's own profile speed (m/s) in the middle of :func:`_bend_lane`'s
    bend, the car at the lane's start at 5 m/s, planning with ``lateral_factor`` where the
    path has room (``exploration_lateral_safety_factor``)."""
    from dataclasses import replace

    from common.messages import ConeMap, MapState, PoseEstimate
    from orchestrator.config import AppConfig
    from planner.path_planner import PathPlanner

    config = AppConfig()
    planner_config = replace(config.planner, exploration_lateral_safety_factor=lateral_factor)
    cones, colours = _bend_lane(width_m)
    n = len(cones)
    cone_map = ConeMap(xy_m=cones, covariance=np.tile(np.eye(2) * 0.01, (n, 1, 1)),
                       colour=colours, size=np.ones(n, np.int64), confidence=np.ones(n),
                       ids=np.arange(n, dtype=np.int64))
    pose = PoseEstimate(0.0, 0.0, 0.0, 0.0, 5.0, 0.0, 0.0, np.eye(3) * 1e-4)
    planner = PathPlanner(planner_config, config.car)
    state = MapState(0.0, pose, cone_map, loop_closed=False)
    planner.start_autonomous(state)
    assert planner.explore(state) and planner.exploring
    assert planner.frame is not None
    mid = np.radians(45.0)
    s_mid = planner.frame.project(6.0 + 10.0 * np.sin(mid), 10.0 * (1.0 - np.cos(mid)))[0]
    return float(planner.speed_at(np.array([s_mid]))[0])


def test_exploring_the_car_corners_nearer_its_limit_only_where_the_lane_has_room() -> None:
    """In a 4 m lane's bend the exploring profile corners at
    ``exploration_lateral_safety_factor`` of the lateral limit instead of
    ``lateral_safety_factor``: sqrt(0.7 / 0.6), 8 % faster. In a 3.2 m lane's bend (its least
    room beside the body within ``ROOM_WINDOW_M`` below ``exploration_tight_room_m``) it
    corners as it did: the car strays from its plan in a bend at speed, and a lane near the
    rules' narrowest leaves no room for it (EPFL track 4 hit a cone at 0.7 everywhere)."""
    base = PlannerConfig().lateral_safety_factor
    full_gain = np.sqrt(0.7 / base)
    wide_slow, wide_fast = (_exploring_bend_speed_mps(4.0, f) for f in (base, 0.7))
    assert wide_fast / wide_slow == pytest.approx(full_gain, rel=0.01)
    tight_slow, tight_fast = (_exploring_bend_speed_mps(3.2, f) for f in (base, 0.7))
    assert tight_fast == pytest.approx(tight_slow, rel=1e-9)
    assert tight_fast < wide_fast
