"""A loop found in the cones that strays from the way the car drove is not the track
(:meth:`planner.explored_lap.ExploredLap.loop_refusal`, ``loop_off_driven``)."""

from __future__ import annotations

import math

import numpy as np

from common.messages import ConeMap, MapState, PoseEstimate
from planner.config import PlannerConfig
from planner.explored_lap import ExploredLap

STRAIGHT_M, RADIUS_M = 40.0, 10.0


def _stadium(step_m: float) -> np.ndarray:
    """A stadium loop from the origin heading +x, turning left: two 40 m straights and two
    half circles of 10 m, points about ``step_m`` apart (K, 2)."""
    pts = []
    for x in np.arange(0.0, STRAIGHT_M, step_m):
        pts.append((x, 0.0))
    for a in np.arange(0.0, math.pi, step_m / RADIUS_M):
        pts.append((STRAIGHT_M + RADIUS_M * math.sin(a), RADIUS_M - RADIUS_M * math.cos(a)))
    for x in np.arange(STRAIGHT_M, 0.0, -step_m):
        pts.append((x, 2.0 * RADIUS_M))
    for a in np.arange(0.0, math.pi, step_m / RADIUS_M):
        pts.append((-RADIUS_M * math.sin(a), RADIUS_M + RADIUS_M * math.cos(a)))
    return np.asarray(pts)


def _explored_lap() -> ExploredLap:
    """A car that drove the stadium once, back at its start."""
    lap = ExploredLap((0.0, 0.0), 0.0, PlannerConfig())
    cones = ConeMap.empty()
    for x, y in np.vstack([_stadium(0.25), [[0.0, 0.0]]]):
        lap.update(float(x), float(y), MapState(0.0, PoseEstimate(0.0, float(x), float(y), 0.0),
                                                cones))
    return lap


def test_the_gates_of_the_driven_lap_are_the_track() -> None:
    """Gate middles every 5 m, half a metre beside where the car drove: the track."""
    lap = _explored_lap()
    gates = _stadium(5.0)
    centre = np.array([STRAIGHT_M / 2.0, RADIUS_M])
    outward = gates - centre
    gates = gates + 0.5 * outward / np.linalg.norm(outward, axis=1)[:, None]
    assert lap.loop_off_driven_m(gates) < 1.0
    assert lap.loop_refusal(gates, "trackdrive") == ""


def test_a_loop_across_the_inside_of_a_bend_is_refused() -> None:
    """The same gates but one bend's gates left out (paired across its inside): the loop's
    chord passes the bend's middle 10 m from where the car drove."""
    lap = _explored_lap()
    gates = _stadium(5.0)
    in_bend = (gates[:, 0] > STRAIGHT_M + 0.1)
    cut = gates[~in_bend]
    assert lap.loop_off_driven_m(cut) > 9.0
    assert lap.loop_refusal(cut, "trackdrive") == "loop_off_driven"
    # the check is the chords', not only the gates': each gate is on the driven way
    assert np.all(np.hypot(*(cut[:, None, :] - _stadium(0.25)[None, :, :]).transpose(2, 0, 1)
                           ).min(axis=1) < 0.2)
