"""The explored lap is counted where the car crosses the start line, even when the line moves
under the car as it crosses (:class:`planner.explored_lap.ExploredLap`)."""

from __future__ import annotations

import numpy as np

from common.messages import ConeColour, ConeMap, ConeSize, MapState, PoseEstimate
from planner.config import PlannerConfig
from planner.explored_lap import ExploredLap


def _big_cones(xy: list[tuple[float, float]]) -> ConeMap:
    n = len(xy)
    return ConeMap(np.asarray(xy, np.float64), np.tile(np.eye(2) * 1e-4, (n, 1, 1)),
                   np.full(n, int(ConeColour.BIG_ORANGE)), np.full(n, int(ConeSize.LARGE)),
                   np.ones(n), np.arange(n))


def _drive(moved: ConeMap) -> ExploredLap:
    """A car 17.4 m down the track from where it is first seen, driving +x through a start
    line at x = 5.53 (big cones at y = +-2); the map changes to ``moved`` at the step that
    crosses it (from x = 5.4 to 6.4)."""
    lap = ExploredLap((0.0, 0.0), 0.0, PlannerConfig())
    line = _big_cones([(5.53, 2.0), (5.53, -2.0)])
    for x in np.arange(-12.0, 5.41, 0.2):
        lap.update(float(x), 0.0, MapState(0.0, PoseEstimate(0.0, float(x), 0.0, 0.0), line))
    for x in (6.4, 7.4, 8.4):
        lap.update(x, 0.0, MapState(0.0, PoseEstimate(0.0, x, 0.0, 0.0), moved))
    return lap


def test_the_lap_counts_where_the_car_crosses_the_start_line() -> None:
    assert _drive(_big_cones([(5.53, 2.0), (5.53, -2.0)])).laps == 1


def test_a_start_line_that_jumps_behind_the_car_as_it_crosses_still_counts_the_lap() -> None:
    # EUFS Jellybean, autocross seed 9: the map froze as the car crossed, its big cones merged
    # and the line through them moved 1 m back and turned 40 degrees, behind the car's last
    # position too; the lap went uncounted and the car drove a second one.
    lap = _drive(_big_cones([(3.5, 2.0), (5.0, -2.0)]))
    assert lap.laps == 1
