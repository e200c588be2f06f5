"""The racing line built in a process of its own (``drive``): the planner drives the centre line
meanwhile and swaps the racing line in when it is done, laps carried over."""

from __future__ import annotations

import copy
import math
import time
from typing import Any

import numpy as np
import pytest
from planner_closed_loop_helpers import cone_map

from common.messages import MapState, PoseEstimate
from orchestrator.config import AppConfig
from planner.path_planner import PathPlanner
from simulator.tracks import load_track


def _planner(background: bool) -> tuple[PathPlanner, object]:
    config = AppConfig()
    config.planner.racing_line_background = background
    track = load_track("gen:2")
    planner = PathPlanner(config.planner, config.car)
    for p in track.centreline_xy_m[::3]:
        planner.book.record(float(p[0]), float(p[1]))
    return planner, track


def _state(track: object, t_s: float, i: int) -> MapState:
    centre = track.centreline_xy_m  # type: ignore[attr-defined]
    x, y = centre[i % len(centre)]
    dx, dy = centre[(i + 1) % len(centre)] - centre[i % len(centre)]
    pose = PoseEstimate(t_s, float(x), float(y), math.atan2(dy, dx), 5.0, 0.0, 0.0,
                        np.eye(3) * 1e-4)
    cones = cone_map(track.cones_xy_m, track.colours)  # type: ignore[attr-defined]
    return MapState(t_s, pose, cones, loop_closed=True)


@pytest.fixture(scope="module")
def inline_race() -> tuple[Any, Any, Any]:
    """gen:2, its racing line built in line by a planner's start (the frame), and the racing
    line that line guides (what the background worker hands over): built once for the module,
    as each build takes the planner many seconds."""
    from planner.race_job import build_race_line

    planner, track = _planner(background=False)
    planner.start_autonomous(_state(track, 0.0, 0))
    guide = planner.frame
    assert guide is not None
    cones = cone_map(track.cones_xy_m, track.colours)  # type: ignore[attr-defined]
    line = build_race_line(cones.xy_m, cones.colour, guide.xy_m, planner.config, planner.car,
                           planner.limits)
    return track, guide, line


@pytest.mark.slow
def test_the_racing_line_is_swapped_in_when_built_and_the_laps_carry_on(
        inline_race: tuple[Any, Any, Any]) -> None:
    track, expected, _ = inline_race

    planner, _ = _planner(background=True)
    try:
        planner.start_autonomous(_state(track, 0.0, 0))
        first = planner.frame
        assert first is not None and first.closed  # the centre line, at once
        n = len(track.centreline_xy_m)
        laps: list[int] = []
        frames = []
        for k in range(1, int(1.5 * n)):  # a lap and a half along the centre line
            plan = planner.plan(_state(track, 0.1 * k, k), 0.1 * k)
            assert len(plan.manoeuvre) > 0
            laps.append(planner.lap)
            frames.append(planner.frame)
        deadline = time.monotonic() + 120.0  # a busy machine: the worker process may be slow
        while planner.frame is first and time.monotonic() < deadline:
            time.sleep(0.05)
            planner.plan(_state(track, 0.1 * k, k), 0.1 * k)
            laps.append(planner.lap)
        assert planner.frame is not first, "the racing line was never swapped in"
        raced = planner.frame
        assert raced is not None and raced.closed
        assert raced.length_m == expected.length_m  # the same line as built in line
        assert np.allclose(raced.xy_m, expected.xy_m)
        # one lap counted, once, wherever in the lap the swap fell
        assert laps[-1] == 1
        assert np.all(np.diff(laps) >= 0) and np.count_nonzero(np.diff(laps)) == 1
        # the lap ends near where the car passed its start, not where the swap fell
        first_lap = int(np.argmax(np.asarray(laps) == 1)) + 1
        assert abs(first_lap - n) < 0.1 * n
    finally:
        planner.close()


class _ReadyAt:
    """A stand-in for the background worker (a unit test's mock): the line is done at the
    ``at``-th poll, so the swap falls at a chosen place in the lap."""

    def __init__(self, line: object, at: int) -> None:
        self.line, self.at, self.polls = line, at, 0

    @property
    def pending(self) -> bool:
        return self.line is not None

    def poll(self) -> object:
        self.polls += 1
        if self.polls < self.at:
            return None
        line, self.line = self.line, None
        return line

    def close(self) -> None:
        pass


@pytest.mark.parametrize("where", [0.3, 0.98, 1.02])
def test_a_lap_is_counted_once_wherever_the_swap_falls(
        where: float, inline_race: tuple[Any, Any, Any]) -> None:
    """The racing line's start may lie a little before or after the centre line's: a swap just
    before or just after the start neither loses the lap nor counts it twice."""
    track, _, built = inline_race
    line = copy.deepcopy(built)  # the planner takes it over
    n = len(track.centreline_xy_m)  # type: ignore[attr-defined]
    planner2, _ = _planner(background=False)
    planner2.config.racing_line = False  # the centre line first, as drive drives it
    planner2.start_autonomous(_state(track, 0.0, 0))
    planner2.config.racing_line = True
    planner2._race_worker = _ReadyAt(line, int(where * n))  # type: ignore[assignment]
    centre_line = planner2.frame
    laps = []
    for k in range(1, int(1.6 * n)):
        planner2.plan(_state(track, 0.1 * k, k), 0.1 * k)
        laps.append(planner2.lap)
    assert planner2.frame is not centre_line  # swapped
    assert laps[-1] == 1 and np.count_nonzero(np.diff(laps)) == 1
    first_lap = int(np.argmax(np.asarray(laps) == 1)) + 1
    assert abs(first_lap - n) < 0.1 * n
