"""Tentative cones (issue 45): the camera's cones beyond the LiDAR's landmarks, published for
the exploring planner, never in the map the car localises on."""

from __future__ import annotations

import numpy as np

from common.messages import CameraCones, ConeColour, ConeDetection, ConeMap
from mapper.config import MapperConfig, TentativeConfig
from mapper.tentative_cones import TentativeCones, with_tentative

BLUE, YELLOW = int(ConeColour.BLUE), int(ConeColour.YELLOW)
NO_LANDMARKS = np.zeros((0, 2))


def _frame(tc: TentativeCones, xy: list[tuple[float, float]], t_s: float,
           landmarks: np.ndarray = NO_LANDMARKS, colour: int = BLUE,
           car: tuple[float, float] = (0.0, 0.0)) -> None:
    n = len(xy)
    tc.add(np.array(xy, np.float64).reshape(-1, 2), np.full(n, colour, np.int64),
           np.ones(n), t_s, landmarks, car)


def test_a_far_camera_cone_is_published_once_seen_twice_at_its_mean_position() -> None:
    tc = TentativeCones(TentativeConfig())
    _frame(tc, [(18.0, 2.0)], 0.0)
    assert len(tc.cone_map(NO_LANDMARKS)) == 0  # one frame: not yet
    _frame(tc, [(18.4, 1.8)], 0.05)
    cones = tc.cone_map(NO_LANDMARKS)
    assert len(cones) == 1
    # two frames at nearly one range: nearly their plain mean, the nearer a little more
    assert np.allclose(cones.xy_m[0], [18.2, 1.9], atol=0.01)
    assert cones.xy_m[0, 0] < 18.2
    assert cones.colour[0] == BLUE
    assert cones.confidence[0] < 1.0 and cones.ids[0] < 0
    # the mean's own variance: the camera's at about 18 m, halved by two frames
    sigma = TentativeConfig().sigma_at_zero_m + TentativeConfig().sigma_per_m * 18.3
    assert np.allclose(cones.covariance[0], np.eye(2) * sigma**2 / 2.0, rtol=0.03)


def test_a_nearer_frame_counts_more_by_the_cameras_noise_model() -> None:
    cfg = TentativeConfig()
    tc = TentativeCones(cfg)
    _frame(tc, [(20.0, 2.0)], 0.0)
    _frame(tc, [(20.0, 2.6)], 0.05, car=(9.0, 0.0))  # the car drove on: seen from 11.3 m
    w_far = 1.0 / (cfg.sigma_at_zero_m + cfg.sigma_per_m * np.hypot(20.0, 2.0)) ** 2
    w_near = 1.0 / (cfg.sigma_at_zero_m + cfg.sigma_per_m * np.hypot(11.0, 2.6)) ** 2
    expected_y = (2.0 * w_far + 2.6 * w_near) / (w_far + w_near)
    assert len(tc) == 1 and np.isclose(tc.xy_m[0, 1], expected_y)
    assert expected_y > 2.35  # nearer the near frame's than the plain mean (2.3)


def test_two_tracks_of_one_cone_fold_into_one() -> None:
    tc = TentativeCones(TentativeConfig())
    gate = float(tc.gate_m(np.array([18.5]))[0])
    _frame(tc, [(18.0, 2.0)], 0.0)
    _frame(tc, [(18.1 + gate, 2.0)], 0.05)  # too far off the first: a second track
    assert len(tc) == 2
    _frame(tc, [(18.05 + 0.5 * gate, 2.0)], 0.1)  # between: one moves within the gate
    assert len(tc) == 1
    assert tc.frames.tolist() == [3]
    cones = tc.cone_map(NO_LANDMARKS)
    assert len(cones) == 1 and 18.0 < cones.xy_m[0, 0] < 18.1 + gate


def test_the_gate_grows_with_the_cameras_noise_at_range() -> None:
    """With ``gate_sigmas`` set (a camera that sees far), far away one frame in a few places
    a cone well aside (three sigmas at 27 m are 1.8 m): it is still that cone, not a second
    one in the lane; near the car, where the camera is exact, two cones 1.2 m apart stay two
    (the gate is ``gate_m`` there). Unset (the default), the gate is ``gate_m``."""
    assert TentativeConfig().gate_sigmas == 0.0
    plain = TentativeCones(TentativeConfig())
    assert plain.gate_m(np.array([27.0]))[0] == plain.config.gate_m
    _frame(plain, [(27.0, 2.0)], 0.0)
    _frame(plain, [(27.0, 0.6)], 0.05)
    assert len(plain) == 2
    cfg = TentativeConfig(gate_sigmas=3.0)
    tc = TentativeCones(cfg)
    sigma_27 = cfg.sigma_at_zero_m + cfg.sigma_per_m * 27.0
    assert tc.gate_m(np.array([27.0]))[0] == np.float64(cfg.gate_sigmas * sigma_27)
    assert tc.gate_m(np.array([5.0]))[0] == cfg.gate_m
    _frame(tc, [(27.0, 2.0)], 0.0)
    _frame(tc, [(27.0, 0.6)], 0.05)  # 1.4 m aside, 2.4 sigmas
    _frame(tc, [(27.0, 2.1)], 0.1)
    assert len(tc) == 1 and tc.frames.tolist() == [3]
    assert 1.4 < tc.cone_map(NO_LANDMARKS).xy_m[0, 1] < 2.0
    near = TentativeCones(cfg)
    _frame(near, [(11.0, 2.0), (11.0, 0.8)], 0.0)
    _frame(near, [(11.0, 2.0), (11.0, 0.8)], 0.05)
    assert len(near.cone_map(NO_LANDMARKS)) == 2


def test_a_tentative_cone_just_over_a_metre_from_a_landmark_is_that_landmark() -> None:
    cfg = TentativeConfig()
    tc = TentativeCones(cfg)
    _frame(tc, [(18.0, 2.0)], 0.0)
    _frame(tc, [(18.0, 2.0)], 0.05)
    assert len(tc.cone_map(NO_LANDMARKS)) == 1
    landmark = np.array([[16.8, 2.0]])  # the LiDAR's: 1.2 m nearer the car
    assert 1.2 < cfg.landmark_gate_m
    assert len(tc.cone_map(landmark)) == 0
    far = np.array([[18.0 - cfg.landmark_gate_m - 0.1, 2.0]])
    assert len(tc.cone_map(far)) == 1


def test_a_landmark_takes_over_and_a_near_or_unseen_one_goes() -> None:
    cfg = TentativeConfig()
    tc = TentativeCones(cfg)
    _frame(tc, [(18.0, 2.0), (18.0, -2.0), (25.0, 2.0)], 0.0)
    _frame(tc, [(18.0, 2.0), (18.0, -2.0), (25.0, 2.0)], 0.05)
    assert len(tc.cone_map(NO_LANDMARKS)) == 3
    # the LiDAR has mapped the first: it is that landmark's now
    landmark = np.array([[18.3, 2.1]])
    assert len(tc.cone_map(landmark)) == 2
    # a camera cone on a landmark starts no tentative cone
    _frame(tc, [(18.2, 2.0)], 0.1, landmarks=landmark)
    assert not np.any(np.hypot(*(tc.xy_m - [18.0, 2.0]).T) < 0.5)
    # the car has come near the second (the LiDAR maps a real cone there), and the third
    # has not been seen for longer than max_age_s
    _frame(tc, [(30.0, 0.0)], 0.1 + cfg.max_age_s + 0.01, car=(10.0, -2.0))
    assert not np.any(np.hypot(*(tc.xy_m - [18.0, -2.0]).T) < 0.5)
    assert not np.any(np.hypot(*(tc.xy_m - [25.0, 2.0]).T) < 0.5)


def test_the_colour_is_the_votes_and_with_tentative_appends() -> None:
    tc = TentativeCones(TentativeConfig())
    for k, colour in enumerate((YELLOW, BLUE)):
        _frame(tc, [(18.0, -2.0)], 0.05 * k, colour=colour)
    tentative = tc.cone_map(NO_LANDMARKS)
    assert tentative.colour.tolist() == [int(ConeColour.UNKNOWN)]  # no lead
    _frame(tc, [(18.0, -2.0)], 0.2, colour=YELLOW)
    tentative = tc.cone_map(NO_LANDMARKS)
    assert tentative.colour.tolist() == [YELLOW]
    landmarks = ConeMap(np.array([[5.0, 2.0]]), np.eye(2)[None] * 1e-4, np.array([BLUE]),
                        np.array([1]), np.array([1.0]), np.array([7]))
    both = with_tentative(landmarks, tentative)
    assert len(both) == 2 and both.ids.tolist() == [7, int(tentative.ids[0])]
    assert with_tentative(landmarks, ConeMap.empty()) is landmarks


def test_the_mapper_publishes_them_while_exploring_and_never_after_the_freeze() -> None:
    from common.car import CarConfig
    from mapper.mapper import Mapper

    config = MapperConfig()
    assert config.tentative.enabled  # on by default (issue 45)
    mapper = Mapper(config, CarConfig())
    cones = tuple(ConeDetection(0.0, 18.0, y, colour=ConeColour.BLUE, confidence=0.9)
                  for y in (2.0, -2.0))
    mapper._apply(CameraCones(0.0, cones))
    mapper._apply(CameraCones(0.05, tuple(ConeDetection(0.05, c.x_m, c.y_m, colour=c.colour,
                                                        confidence=0.9) for c in cones)))
    state = mapper._make_state(0.05)
    assert len(state.cones) == 2 and np.all(state.cones.confidence < 1.0)
    mapper.freeze(ConeMap.empty())
    assert len(mapper._make_state(0.1).cones) == 0
    assert len(mapper.tentative) == 0
    # off: the landmarks alone
    off_config = MapperConfig()
    off_config.tentative.enabled = False
    off = Mapper(off_config, CarConfig())
    off._apply(CameraCones(0.0, cones))
    off._apply(CameraCones(0.05, cones))
    assert len(off._make_state(0.05).cones) == 0


def test_the_published_cones_follow_every_change_of_the_cones_and_the_landmarks() -> None:
    """:meth:`TentativeCones.cone_map` is kept between changes (the planner asks at every
    plan): a new cone, a cone a landmark now explains and a new landmark array each show."""
    tc = TentativeCones(TentativeConfig(min_frames=1))
    no_landmarks = np.zeros((0, 2))
    tc.add(np.array([[18.0, 2.0]]), np.array([int(BLUE)]), np.array([0.9]), 0.0,
           no_landmarks, (0.0, 0.0))
    first = tc.cone_map(no_landmarks)
    assert len(first) == 1 and tc.cone_map(no_landmarks) is first
    tc.add(np.array([[18.0, -2.0]]), np.array([int(BLUE)]), np.array([0.9]), 0.05,
           no_landmarks, (0.0, 0.0))
    assert len(tc.cone_map(no_landmarks)) == 2
    landmark_there = np.array([[18.0, 2.1]])
    shown = tc.cone_map(landmark_there)
    assert len(shown) == 1 and shown.xy_m[0, 1] == -2.0
    moved = np.array([[18.0, -2.1]])  # another array: asked again, not the cached answer
    assert tc.cone_map(moved).xy_m[0, 1] == 2.0
