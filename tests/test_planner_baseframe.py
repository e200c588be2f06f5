"""Baseframe: a periodic spline with the curvature of a circle, smoothing, Frenet projection."""

from __future__ import annotations

import math

import numpy as np
import pytest

from common.errors import TrackError
from common.messages import ConeColour
from planner.baseframe import SplineBaseframe, centre_on_cones


def circle(r: float, n: int, noise: float = 0.0, seed: int = 0) -> np.ndarray:
    t = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
    pts = np.stack([r * np.cos(t), r * np.sin(t)], axis=1)
    return pts + np.random.default_rng(seed).normal(0.0, noise, pts.shape)


@pytest.mark.parametrize("r", [5.0, 10.0, 30.0])
def test_circle_has_curvature_one_over_r(r: float) -> None:
    frame = SplineBaseframe(circle(r, 80))
    assert frame.closed
    assert frame.length_m == pytest.approx(2 * math.pi * r, rel=0.02)
    np.testing.assert_allclose(frame.curvature_1pm, 1.0 / r, rtol=0.03)
    # heading is tangent (counter-clockwise: position angle + 90 deg)
    x, y = frame.xy_m[:, 0], frame.xy_m[:, 1]
    expected = np.arctan2(y, x) + np.pi / 2
    err = np.angle(np.exp(1j * (frame.heading_rad - expected)))
    assert np.max(np.abs(err)) < 0.02


def test_noisy_waypoints_make_no_curvature_spikes() -> None:
    r = 20.0
    raw = SplineBaseframe(circle(r, 120, noise=0.1), smoothing_m=0.0)
    smooth = SplineBaseframe(circle(r, 120, noise=0.1))
    assert np.max(np.abs(raw.curvature_1pm - 1 / r)) > 0.1  # the noise is real
    assert np.max(np.abs(smooth.curvature_1pm - 1 / r)) < 0.03


def test_projection_and_frenet_round_trip() -> None:
    frame = SplineBaseframe(circle(10.0, 60))
    s, d = frame.project(11.0, 0.0)
    assert d == pytest.approx(-1.0, abs=0.02)  # outside a CCW circle is right
    assert min(s, frame.length_m - s) < 0.05
    xy = frame.frenet_to_xy(np.array([5.0, 20.0]), np.array([0.5, -0.7]))
    for (px, py), (s0, d0) in zip(xy, [(5.0, 0.5), (20.0, -0.7)], strict=True):
        s1, d1 = frame.project(float(px), float(py), s_hint_m=s0)
        assert s1 == pytest.approx(s0, abs=0.05)
        assert d1 == pytest.approx(d0, abs=0.02)


def test_open_frame_on_a_straight() -> None:
    pts = np.stack([np.linspace(0, 30, 16), np.zeros(16)], axis=1)
    frame = SplineBaseframe(pts, closed=False)
    assert not frame.closed
    assert frame.length_m == pytest.approx(30.0, abs=0.05)
    assert np.max(np.abs(frame.curvature_1pm)) < 1e-3
    s, d = frame.project(12.0, 1.0)
    assert s == pytest.approx(12.0, abs=0.05) and d == pytest.approx(1.0, abs=0.01)


def test_too_few_points_is_a_clear_error() -> None:
    with pytest.raises(TrackError, match="at least"):
        SplineBaseframe(np.array([[0.0, 0.0], [1.0, 0.0], [float("nan"), 0.0]]))


def test_centre_on_cones_moves_the_frame_to_mid_track() -> None:
    r = 20.0
    frame = SplineBaseframe(circle(r + 0.8, 80))  # driven 0.8 m off the middle
    t = np.linspace(0, 2 * np.pi, 60, endpoint=False)
    inner = np.stack([(r - 1.75) * np.cos(t), (r - 1.75) * np.sin(t)], axis=1)
    outer = np.stack([(r + 1.75) * np.cos(t), (r + 1.75) * np.sin(t)], axis=1)
    cones = np.vstack([inner, outer])  # CCW: blue (left) inside, yellow outside
    colours = np.r_[np.full(60, ConeColour.BLUE), np.full(60, ConeColour.YELLOW)]
    centred = centre_on_cones(frame, cones, colours)
    radius = np.hypot(centred.xy_m[:, 0], centred.xy_m[:, 1])
    np.testing.assert_allclose(radius, r, atol=0.1)
