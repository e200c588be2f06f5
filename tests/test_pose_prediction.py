"""The pose carried forward to the control tick by its own motion (a constant turn)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from common.messages import PoseEstimate
from controller.pose_prediction import predict_pose


def _pose(t: float, x: float = 0.0, y: float = 0.0, yaw: float = 0.0, vx: float = 15.0,
          vy: float = 0.0, rate: float = 0.0) -> PoseEstimate:
    return PoseEstimate(t, x, y, yaw, vx, vy, rate, np.diag([0.01, 0.01, 0.0004]))


def test_a_pose_0_1_s_old_at_15_m_s_moves_1_5_m_along_its_heading() -> None:
    moved = predict_pose(_pose(1.0, x=2.0, y=3.0, yaw=math.pi / 2), 1.1, 0.3)
    assert (moved.x_m, moved.y_m) == pytest.approx((2.0, 4.5), abs=1e-9)
    assert moved.yaw_rad == pytest.approx(math.pi / 2)
    assert moved.timestamp_s == 1.0  # its age is still its age
    # across the travel (x here) the yaw's uncertainty has grown the position's
    assert moved.covariance[0, 0] == pytest.approx(0.01 + 0.0004 * 1.5**2)
    assert moved.covariance[1, 1] == pytest.approx(0.01)


def test_on_a_constant_turn_it_follows_the_circle() -> None:
    """At 10 m/s and 0.5 rad/s (a 20 m radius) from (0, 0) heading +x, the centre is at
    (0, 20): after 0.3 s the car is on that circle, 0.15 rad round it."""
    moved = predict_pose(_pose(0.0, vx=10.0, rate=0.5), 0.3, 0.3)
    radius, turned = 20.0, 0.15
    assert moved.x_m == pytest.approx(radius * math.sin(turned), abs=1e-9)
    assert moved.y_m == pytest.approx(radius * (1.0 - math.cos(turned)), abs=1e-9)
    assert moved.yaw_rad == pytest.approx(turned)


def test_sideslip_moves_it_sideways_too() -> None:
    moved = predict_pose(_pose(0.0, vx=0.0, vy=2.0), 0.1, 0.3)
    assert (moved.x_m, moved.y_m) == pytest.approx((0.0, 0.2), abs=1e-12)


def test_the_prediction_is_capped_and_a_current_or_bad_pose_is_left_alone() -> None:
    capped = predict_pose(_pose(0.0), 2.0, 0.3)
    assert capped.x_m == pytest.approx(15.0 * 0.3)
    current = _pose(5.0)
    assert predict_pose(current, 5.0, 0.3) is current  # the simulator's Main: no change
    assert predict_pose(current, 4.9, 0.3) is current  # a pose from the future: as it is
    assert predict_pose(current, 5.2, 0.0) is current  # prediction off
    bad = _pose(0.0, vx=math.nan)
    assert predict_pose(bad, 0.1, 0.3) is bad
