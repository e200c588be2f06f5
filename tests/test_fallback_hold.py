"""After a fallback the plans hold the car's speed for ``planner.fallback_hold_s``
(planner/path_planner.py ``_start_hold``).

With a camera mapping cones 30 m away (EUFS ``BM_text_bubble``, seed 1) the cones of a bend
ahead refused every manoeuvre in one plan and none in the next, ten times a second: each
fallback braked the car, each plan after it drove it back to full speed, and it entered the bend
at 13 m/s and hit two cones. Held, the car slows over those plans instead."""

from __future__ import annotations

import numpy as np
import pytest
from planner_closed_loop_helpers import cone_map

from common.messages import ConeColour, ConeMap, MapState, PoseEstimate
from orchestrator.config import AppConfig
from planner.path_planner import PathPlanner

SPEED_MPS = 12.0
"""The car's speed: below the exploring cap (14 m/s) a straight lane allows."""


def _lane() -> tuple[np.ndarray, np.ndarray]:
    """A straight 3.5 m lane, a cone every 5 m a side for 60 m: (xy (N, 2), colours (N,))."""
    x = np.arange(0.0, 65.0, 5.0)
    xy = np.r_[np.c_[x, np.full(len(x), 1.75)], np.c_[x, np.full(len(x), -1.75)]]
    colours = np.r_[np.full(len(x), int(ConeColour.BLUE)),
                    np.full(len(x), int(ConeColour.YELLOW))]
    return xy, colours


def _blocked(at_m: float) -> ConeMap:
    """The lane with cones across it ``at_m`` ahead: no manoeuvre passes, the car stops."""
    xy, colours = _lane()
    wall = np.c_[np.full(5, at_m), np.linspace(-1.2, 1.2, 5)]
    return cone_map(np.r_[xy, wall], np.r_[colours, np.full(5, int(ConeColour.UNKNOWN))])


def _planner(hold_s: float) -> PathPlanner:
    config = AppConfig()
    config.planner.fallback_hold_s = hold_s
    planner = PathPlanner(config.planner, config.car)
    clear = cone_map(*_lane())
    planner.start_autonomous(MapState(0.0, PoseEstimate(0.0, 0.0, 0.0, 0.0, SPEED_MPS), clear))
    return planner


def _top_speed_mps(planner: PathPlanner, t_s: float, cones: ConeMap,
                   speed_mps: float = SPEED_MPS) -> tuple[int, float]:
    """(chosen index, fastest target (m/s)) of a plan at ``t_s`` with the car at x = 0."""
    plan = planner.plan(MapState(t_s, PoseEstimate(t_s, 0.0, 0.0, 0.0, speed_mps), cones), t_s)
    return plan.chosen_index, float(plan.manoeuvre.speed_mps.max())


@pytest.mark.parametrize("hold_s", [0.0, 1.0])
def test_a_clear_plan_after_a_fallback_asks_no_more_speed_until_the_hold_ends(
        hold_s: float) -> None:
    planner = _planner(hold_s)
    clear = cone_map(*_lane())
    best, top = _top_speed_mps(planner, 0.1, clear)
    assert best >= 0 and top > SPEED_MPS + 1.0  # the lane alone lets the car speed up
    best, top = _top_speed_mps(planner, 0.2, _blocked(12.0))
    assert best == -1 and top < SPEED_MPS  # the fallback: a stop
    best, top = _top_speed_mps(planner, 0.3, clear)
    assert best >= 0
    if hold_s > 0.0:
        assert top <= SPEED_MPS + 1e-9  # held at the speed the fallback found the car at
    else:
        assert top > SPEED_MPS + 1.0  # off: straight back to full speed
    # after the hold, the lane's own speed again
    best, top = _top_speed_mps(planner, 0.2 + hold_s + 0.05, clear)
    assert best >= 0 and top > SPEED_MPS + 1.0


def test_a_second_fallback_holds_to_the_lower_speed_and_restarts_the_hold() -> None:
    planner = _planner(1.0)
    _top_speed_mps(planner, 0.1, cone_map(*_lane()))
    assert _top_speed_mps(planner, 0.2, _blocked(12.0))[0] == -1
    slower = SPEED_MPS - 2.0
    assert _top_speed_mps(planner, 0.9, _blocked(10.0), slower)[0] == -1
    # the first hold would have ended at 1.2 s; the second holds the slower speed to 1.9 s
    best, top = _top_speed_mps(planner, 1.5, cone_map(*_lane()), SPEED_MPS)
    assert best >= 0 and top <= slower + 1e-9


def test_a_fallback_at_the_fallbacks_own_pace_holds_nothing() -> None:
    """Crawling round a hairpin the car stops and goes on plan after plan: a hold there would
    ratchet it down to walking pace (camera dead, EUFS SmallCircle then stopped)."""
    planner = _planner(1.0)
    slow = planner.config.fallback_speed_mps - 0.5
    _top_speed_mps(planner, 0.1, cone_map(*_lane()), slow)
    assert _top_speed_mps(planner, 0.2, _blocked(6.0), slow)[0] == -1
    best, top = _top_speed_mps(planner, 0.3, cone_map(*_lane()), slow)
    assert best >= 0 and top > planner.config.fallback_speed_mps
