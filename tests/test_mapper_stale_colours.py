"""A camera that dies while the car explores takes its colours and its tentative cones with it
(``mapper.fusion.colour_stale_s``): the planner then explores as with no camera at all."""

from __future__ import annotations

import numpy as np
import pytest

from common.car import CarConfig
from common.messages import CameraCones, ConeColour, ConeDetection, ConeMap
from mapper.colour_votes import without_colours
from mapper.config import MapperConfig
from mapper.mapper import Mapper

BLUE, YELLOW, UNKNOWN = int(ConeColour.BLUE), int(ConeColour.YELLOW), int(ConeColour.UNKNOWN)


def _coloured_landmarks() -> ConeMap:
    return ConeMap(np.array([[5.0, 2.0], [5.0, -2.0]]), np.tile(np.eye(2) * 1e-4, (2, 1, 1)),
                   np.array([BLUE, YELLOW]), np.array([1, 1]), np.ones(2), np.array([0, 1]))


def _camera_frame(t_s: float) -> CameraCones:
    return CameraCones(t_s, tuple(ConeDetection(t_s, 18.0, y, colour=ConeColour.BLUE,
                                                confidence=0.9) for y in (2.0, -2.0)))


def test_without_colours_keeps_everything_but_the_colours() -> None:
    cones = _coloured_landmarks()
    plain = without_colours(cones)
    assert plain.colour.tolist() == [UNKNOWN, UNKNOWN]
    assert np.array_equal(plain.xy_m, cones.xy_m) and np.array_equal(plain.ids, cones.ids)
    assert cones.colour.tolist() == [BLUE, YELLOW]  # the map's own are untouched
    assert without_colours(plain) is plain


@pytest.fixture
def mapper(monkeypatch: pytest.MonkeyPatch) -> Mapper:
    m = Mapper(MapperConfig(), CarConfig())
    monkeypatch.setattr(m, "_cones", _coloured_landmarks)  # two landmarks the camera coloured
    return m


def test_a_live_camera_keeps_the_colours_and_the_tentative_cones(mapper: Mapper) -> None:
    mapper._apply(_camera_frame(0.0))
    mapper._apply(_camera_frame(0.05))
    stale_s = mapper.config.fusion.colour_stale_s
    for now_s in (0.05, 0.05 + 0.9 * stale_s):
        cones = mapper._make_state(now_s).cones
        assert len(cones) == 4  # two landmarks, two tentative cones
        assert cones.colour[:2].tolist() == [BLUE, YELLOW]


def test_a_dead_camera_takes_its_colours_and_tentative_cones(mapper: Mapper) -> None:
    mapper._apply(_camera_frame(0.0))
    mapper._apply(_camera_frame(0.05))
    cones = mapper._make_state(0.05 + mapper.config.fusion.colour_stale_s + 0.1).cones
    assert len(cones) == 2 and np.all(cones.ids >= 0)  # the landmarks alone
    assert cones.colour.tolist() == [UNKNOWN, UNKNOWN]
    # it comes back: so do the colours
    mapper._apply(_camera_frame(2.0))
    assert mapper._make_state(2.0).cones.colour[:2].tolist() == [BLUE, YELLOW]


def test_a_camera_never_heard_and_a_frozen_map_keep_the_colours(mapper: Mapper) -> None:
    # no camera at all: nothing of its to take (the colours came from elsewhere)
    assert mapper._make_state(10.0).cones.colour.tolist() == [BLUE, YELLOW]
    mapper._apply(_camera_frame(0.0))
    mapper.freeze(_coloured_landmarks())
    assert mapper._make_state(10.0).cones.colour.tolist() == [BLUE, YELLOW]
