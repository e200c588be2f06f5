"""A manoeuvre starts where the car stands, heading where it heads (planner/manoeuvres.py).

The first target state is where the steering law finds the car after each new plan, and the
clearance check places the car's body there with that heading. Its heading had been taken
from a first-order difference over the first step, the heading half a step (0.25 m) along:
on a hairpin at the lock that is 5 degrees more turned than the car, 0.2 m at its front corner.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from common.car import CarConfig
from planner.baseframe import SplineBaseframe
from planner.config import PlannerConfig
from planner.manoeuvres import ManoeuvreGenerator

RADIUS_M = 2.8
"""A hairpin's line near the lock (the lock's circle is 2.67 m)."""


def _hairpin_frame() -> SplineBaseframe:
    """Half a turn to the left on ``RADIUS_M`` about (0, RADIUS_M), from the origin heading +x,
    after a 6 m straight."""
    straight = np.stack([np.linspace(-6.0, -0.25, 24), np.zeros(24)], axis=1)
    a = np.linspace(0.0, math.pi, 60)
    arc = np.stack([RADIUS_M * np.sin(a), RADIUS_M * (1.0 - np.cos(a))], axis=1)
    return SplineBaseframe(np.vstack([straight, arc]), False, step_m=0.25)


@pytest.mark.parametrize("yaw_off_rad", [0.0, -0.08, 0.08])
def test_every_candidate_starts_at_the_car_with_its_heading(yaw_off_rad: float) -> None:
    frame = _hairpin_frame()
    s0 = float(frame.project(1.0, RADIUS_M - math.sqrt(RADIUS_M**2 - 1.0))[0])
    x0, y0, heading0, _ = (float(v) for v in frame.sample(s0))
    yaw = heading0 + yaw_off_rad
    generator = ManoeuvreGenerator(PlannerConfig(), CarConfig())
    cands, _ = generator.generate(frame, s0, 0.0, yaw, 2.5, np.zeros((0, 2)), None)
    assert cands
    for cand in cands:
        assert cand.xy_m[0] == pytest.approx([x0, y0], abs=1e-6)
        # half a step of the path's turn would be 0.5 * 0.5 m / 2.8 m = 0.09 rad
        assert abs(math.remainder(cand.heading_rad[0] - yaw, 2.0 * math.pi)) < 0.01
