"""The racing line built in a process of its own (``drive``): the planner drives the centre line
meanwhile and swaps the racing line in when it is done, laps carried over."""

from __future__ import annotations

import math
import time

import numpy as np
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


def test_the_racing_line_is_swapped_in_when_built_and_the_laps_carry_on() -> None:
    inline, track = _planner(background=False)
    inline.start_autonomous(_state(track, 0.0, 0))
    assert inline.frame is not None
    expected = inline.frame

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
