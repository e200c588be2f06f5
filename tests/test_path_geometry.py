"""The manoeuvres' heading and curvature by finite differences (planner/manoeuvres.py
``_path_geometry``), at the ends of a path as in its middle.

The first point is where the car stands: the steering law takes the heading there as the
path's, and the clearance check places the car's body with it. A first-order difference reads
that heading half a step along the path: on a hairpin's line near the lock (2.8 m, 0.5 m steps)
0.09 rad more turned than the car, 0.2 m at its front corner."""

from __future__ import annotations

import math

import numpy as np
import pytest

from planner.manoeuvres import _path_geometry

RADIUS_M = 2.8
STEP_M = 0.5


def _arc(start_rad: float = 0.3, points: int = 12) -> tuple[np.ndarray, np.ndarray]:
    """Points every ``STEP_M`` along a circle of ``RADIUS_M`` about the origin, turning left
    (counter-clockwise), and the tangent's heading (rad) at each."""
    angle = start_rad + np.arange(points) * STEP_M / RADIUS_M
    xy = RADIUS_M * np.stack([np.cos(angle), np.sin(angle)], axis=1)
    return xy, angle + 0.5 * math.pi


def test_the_heading_and_curvature_at_the_ends_are_the_paths_own() -> None:
    xy, tangent = _arc()
    heading, kappa = _path_geometry(xy)
    error = np.abs(np.remainder(heading - tangent + math.pi, 2.0 * math.pi) - math.pi)
    # a chord's heading differs from the tangent's by (step / radius)^2 / 24 at second order,
    # half a step's turn (0.09 rad) at first
    half_step_turn = 0.5 * STEP_M / RADIUS_M
    assert error.max() < 0.05 * half_step_turn
    assert kappa == pytest.approx(np.full(len(xy), 1.0 / RADIUS_M), rel=0.03)


def test_every_path_of_a_batch_is_computed_as_if_alone() -> None:
    left, _ = _arc()
    right = left * np.array([1.0, -1.0])  # the mirror image: the same bend to the right
    heading, kappa = _path_geometry(np.stack([left, right]))
    alone_heading, alone_kappa = _path_geometry(right)
    assert heading.shape == kappa.shape == (2, len(left))
    assert np.array_equal(heading[1], alone_heading) and np.array_equal(kappa[1], alone_kappa)
    assert kappa[0] == pytest.approx(-kappa[1])
