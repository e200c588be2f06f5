"""Laps on a closed baseframe (planner/lap_counter.py): a lap each time the car passes the
frame's start, none for a start just before it, and the count and the place in the lap kept
when a racing line replaces the frame."""

from __future__ import annotations

import math

import numpy as np

from common.messages import ConeMap, MapState, PoseEstimate
from planner.baseframe import SplineBaseframe
from planner.config import PlannerConfig
from planner.lap_counter import LapCounter

CONFIG = PlannerConfig()
STEP_M = 0.5


def _circle(radius_m: float) -> SplineBaseframe:
    """A closed frame round a circle (counter-clockwise from (radius, 0))."""
    a = np.linspace(0.0, 2.0 * math.pi, 90, endpoint=False)
    return SplineBaseframe(np.c_[radius_m * np.cos(a), radius_m * np.sin(a)], True, step_m=0.25)


def _counter(frame: SplineBaseframe, start_fraction: float) -> LapCounter:
    """A counter reset with the car ``start_fraction`` of a lap along ``frame``."""
    counter = LapCounter(CONFIG.lap_min_fraction, CONFIG.start_line_search_m)
    x, y, _, _ = (float(v) for v in frame.sample(start_fraction * frame.length_m))
    counter.reset(frame, MapState(0.0, PoseEstimate(0.0, x, y, 0.0), ConeMap.empty()), None,
                  0.0)
    return counter


def _drive(counter: LapCounter, frame: SplineBaseframe, metres: float) -> list[tuple[float, int]]:
    """Drive ``metres`` on along ``frame`` as the planner does (project, update, remember the
    projection): (arc length driven, laps) after each step."""
    assert counter.s_hint_m is not None
    s = counter.s_hint_m
    out = []
    for driven in np.arange(STEP_M, metres + 1e-9, STEP_M):
        here = (s + driven) % frame.length_m
        counter.update(frame, here)
        counter.s_hint_m = here
        out.append((float(driven), counter.lap))
    return out


def test_a_lap_counts_each_time_the_car_passes_the_frames_start() -> None:
    frame = _circle(10.0)
    length = frame.length_m
    counter = _counter(frame, 0.3)
    trace = _drive(counter, frame, 2.5 * length)
    first = next(d for d, lap in trace if lap == 1)
    second = next(d for d, lap in trace if lap == 2)
    assert abs(first - 0.7 * length) <= STEP_M  # at the seam, 0.7 of a lap on
    assert abs(second - 1.7 * length) <= STEP_M
    assert counter.lap == 2


def test_a_start_just_before_the_line_does_not_count_its_first_crossing() -> None:
    frame = _circle(10.0)
    length = frame.length_m
    counter = _counter(frame, 0.9)  # 0.1 of a lap before the line: less than lap_min_fraction
    trace = _drive(counter, frame, 1.2 * length)
    assert counter.lap == 1
    first = next(d for d, lap in trace if lap == 1)
    assert abs(first - 1.1 * length) <= STEP_M  # the second crossing, not the first


def test_a_new_frame_keeps_the_laps_done_and_the_place_in_the_lap() -> None:
    """A racing line (a circle 0.5 m wider) replaces the frame 1.6 laps from the start: the
    laps done and the fraction of the lap carry over, and the next lap counts at the seam."""
    old = _circle(10.0)
    counter = _counter(old, 0.3)
    _drive(counter, old, 1.3 * old.length_m)
    laps_done = counter.laps_done(old)
    assert laps_done is not None and abs(laps_done - 1.6) < 0.02
    lap = counter.lap
    new = _circle(10.5)
    assert counter.s_hint_m is not None
    x, y, _, _ = (float(v) for v in old.sample(counter.s_hint_m))
    counter.reset(new, MapState(0.0, PoseEstimate(0.0, x, y, 0.0), ConeMap.empty()), None, 0.0)
    counter.carry_over(new, laps_done)
    counter.lap = max(lap, counter.lap)  # as the planner does
    carried = counter.laps_done(new)
    assert carried is not None and abs(carried - laps_done) < 0.02
    trace = _drive(counter, new, 0.6 * new.length_m)
    second = next(d for d, lap in trace if lap == 2)
    assert abs(second - 0.4 * new.length_m) <= STEP_M + 0.02 * new.length_m
