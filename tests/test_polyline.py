"""The polyline toolkit against analytic truths: a circle, a square, a straight line."""

from __future__ import annotations

import math

import numpy as np
import pytest

from common.polyline import (
    arc_lengths,
    headings,
    nearest_on_polyline,
    polyline_curvature,
    polyline_length,
    resample,
    side_of,
    smooth_closed,
    to_pose_frame,
)

SQUARE = np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0]])


def circle(radius_m: float, n: int = 720) -> np.ndarray:
    a = np.linspace(0.0, 2.0 * math.pi, n, endpoint=False)
    return radius_m * np.stack([np.cos(a), np.sin(a)], axis=1)


def test_lengths_of_a_square() -> None:
    assert polyline_length(SQUARE, closed=True) == pytest.approx(40.0)
    assert polyline_length(SQUARE, closed=False) == pytest.approx(30.0)
    np.testing.assert_allclose(arc_lengths(SQUARE), [0.0, 10.0, 20.0, 30.0])


def test_circle_curvature_is_one_over_radius_and_signed() -> None:
    ccw = circle(20.0)
    np.testing.assert_allclose(polyline_curvature(ccw, closed=True), 1.0 / 20.0, rtol=1e-4)
    np.testing.assert_allclose(polyline_curvature(ccw[::-1], closed=True), -1.0 / 20.0,
                               rtol=1e-4)


def test_resample_keeps_the_shape_at_even_steps() -> None:
    out = resample(SQUARE, 0.5, closed=True)
    assert len(out) == 80
    steps = np.hypot(*np.diff(np.vstack([out, out[:1]]), axis=0).T)
    np.testing.assert_allclose(steps, 0.5, atol=1e-9)
    open_line = resample(np.array([[0.0, 0.0], [3.0, 4.0]]), 1.0, closed=False)
    np.testing.assert_allclose(open_line[-1], [3.0, 4.0])
    assert len(open_line) == 6


def test_nearest_and_side_of() -> None:
    points = np.array([[5.0, -2.0], [5.0, 3.0], [12.0, 5.0]])
    d, seg, t, proj = nearest_on_polyline(points, SQUARE, closed=True)
    np.testing.assert_allclose(d, [2.0, 3.0, 2.0])
    np.testing.assert_array_equal(seg, [0, 0, 1])
    np.testing.assert_allclose(t, [0.5, 0.5, 0.5])
    np.testing.assert_allclose(proj, [[5.0, 0.0], [5.0, 0.0], [10.0, 5.0]])
    lateral, progress = side_of(points, SQUARE, closed=True)
    np.testing.assert_allclose(lateral, [-2.0, 3.0, -2.0])  # left of travel is positive
    np.testing.assert_allclose(progress, [5.0, 5.0, 15.0])


def test_smoothing_a_circle_only_shrinks_it_slightly_and_keeps_a_line() -> None:
    ring = smooth_closed(circle(20.0), 9)
    radius = np.hypot(ring[:, 0], ring[:, 1])
    assert np.all(radius < 20.0) and np.all(radius > 19.99)
    line = np.stack([np.arange(20.0), np.zeros(20)], axis=1)
    np.testing.assert_allclose(smooth_closed(line, 1), line)


def test_headings_and_pose_frame() -> None:
    np.testing.assert_allclose(headings(SQUARE, closed=True),
                               [0.0, math.pi / 2, math.pi, -math.pi / 2])
    local = to_pose_frame(np.array([[11.0, 1.0]]), (10.0, 0.0, math.pi / 2))
    np.testing.assert_allclose(local, [[1.0, -1.0]], atol=1e-12)
