"""Conventions: angle wrapping, seed 002's bearings and formulas, geodetic to world."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from common.conventions import (
    LocalTangentFrame,
    WorldFrame,
    compass_deg_to_enu_yaw,
    enu_yaw_to_compass_deg,
    seed_bearing_to_yaw,
    seed_car_to_world,
    vehicle_to_world,
    world_to_vehicle,
    wrap_angle,
    wrap_angles,
    yaw_to_seed_bearing,
)

# WGS84 constants, for hand-computed expectations.
A_M = 6378137.0
E2 = 6.69437999014e-3


@pytest.mark.parametrize(
    ("angle", "expected"),
    [
        (0.0, 0.0),
        (math.pi, math.pi),
        (-math.pi, math.pi),  # (-pi, pi]: -pi maps to +pi
        (3 * math.pi, math.pi),
        (1.5 * math.pi, -0.5 * math.pi),
        (-1.5 * math.pi, 0.5 * math.pi),
        (2 * math.pi + 0.25, 0.25),
    ],
)
def test_wrap_angle_hand_cases(angle: float, expected: float) -> None:
    assert wrap_angle(angle) == pytest.approx(expected, abs=1e-12)
    assert float(wrap_angles([angle])[0]) == pytest.approx(expected, abs=1e-12)


@given(st.floats(min_value=-1e4, max_value=1e4, allow_nan=False))
def test_wrap_angle_range_and_equivalence(angle: float) -> None:
    w = wrap_angle(angle)
    assert -math.pi < w <= math.pi
    assert math.isclose(math.cos(w), math.cos(angle), abs_tol=1e-9)
    assert math.isclose(math.sin(w), math.sin(angle), abs_tol=1e-9)


@pytest.mark.parametrize(
    ("bearing_deg", "yaw_deg"),
    [(0.0, 90.0), (90.0, 0.0), (180.0, -90.0), (270.0, 180.0), (45.0, 45.0), (-90.0, 180.0)],
)
def test_seed_bearing_to_yaw(bearing_deg: float, yaw_deg: float) -> None:
    yaw = seed_bearing_to_yaw(math.radians(bearing_deg))
    assert wrap_angle(yaw - math.radians(yaw_deg)) == pytest.approx(0.0, abs=1e-12)
    back = yaw_to_seed_bearing(yaw)
    assert wrap_angle(back - math.radians(bearing_deg)) == pytest.approx(0.0, abs=1e-12)


def test_compass_course_to_enu_yaw() -> None:
    assert compass_deg_to_enu_yaw(0.0) == pytest.approx(math.pi / 2)  # north
    assert compass_deg_to_enu_yaw(90.0) == pytest.approx(0.0)  # east
    assert compass_deg_to_enu_yaw(270.0) == pytest.approx(math.pi)  # west
    assert enu_yaw_to_compass_deg(-math.pi / 2) == pytest.approx(180.0)  # south


def test_seed_car_to_world_agrees_with_ours() -> None:
    """Seed 002's formulas (its y-forward car frame, clockwise bearings) give our result."""
    rng = np.random.default_rng(7)
    for _ in range(200):
        obj_fwd, obj_left = rng.uniform(-30, 30, size=2)
        car_x, car_y = rng.uniform(-100, 100, size=2)
        yaw = rng.uniform(-math.pi, math.pi)
        ours = vehicle_to_world([obj_fwd, obj_left], car_x, car_y, yaw)
        # The seed's car frame: y forward, x to the right.
        seed_x, seed_y = seed_car_to_world(-obj_left, obj_fwd, car_x, car_y,
                                           yaw_to_seed_bearing(yaw))
        assert ours == pytest.approx([seed_x, seed_y], abs=1e-9)


def test_vehicle_world_hand_case() -> None:
    # Car at (10, 5) facing +y (yaw 90 deg): a cone 2 m ahead, 1 m left is at (9, 7).
    world = vehicle_to_world([2.0, 1.0], 10.0, 5.0, math.pi / 2)
    assert world == pytest.approx([9.0, 7.0], abs=1e-12)
    assert world_to_vehicle(world, 10.0, 5.0, math.pi / 2) == pytest.approx([2.0, 1.0], abs=1e-12)


def test_enu_known_points() -> None:
    """pymap3d against hand-computed WGS84 radii of curvature."""
    frame = LocalTangentFrame(0.0, 0.0, 0.0)
    e, n, _ = frame.to_enu(0.0, 1e-5, 0.0)
    assert float(e) == pytest.approx(A_M * math.radians(1e-5), abs=1e-6)
    e, n, _ = frame.to_enu(1e-5, 0.0, 0.0)
    meridional_m = A_M * (1 - E2)  # at the equator
    assert float(n) == pytest.approx(meridional_m * math.radians(1e-5), abs=1e-6)

    lat = 45.0
    frame45 = LocalTangentFrame(lat, 10.0, 0.0)
    s2 = math.sin(math.radians(lat)) ** 2
    prime_vertical_m = A_M / math.sqrt(1 - E2 * s2)
    e, _, _ = frame45.to_enu(lat, 10.0 + 1e-5, 0.0)
    assert float(e) == pytest.approx(
        prime_vertical_m * math.cos(math.radians(lat)) * math.radians(1e-5), abs=1e-5
    )


def test_geodetic_world_round_trip_and_rotation() -> None:
    enu = LocalTangentFrame(49.3269, 8.5654, 100.0)
    # Start 3 m east, 4 m north of the first fix, heading north.
    frame = WorldFrame(enu, 3.0, 4.0, math.pi / 2)
    lat, lon = frame.world_to_geodetic(np.array([[10.0, 2.0], [0.0, 0.0]]))
    xy = frame.geodetic_to_world(lat, lon)
    assert xy == pytest.approx(np.array([[10.0, 2.0], [0.0, 0.0]]), abs=1e-6)
    # 10 m ahead of a car heading north is 10 m north of its start.
    en = frame.world_to_enu([10.0, 0.0])
    assert en == pytest.approx([3.0, 14.0], abs=1e-9)
    assert frame.enu_yaw_to_world_yaw(math.pi / 2) == pytest.approx(0.0)
    assert frame.world_yaw_to_enu_yaw(0.0) == pytest.approx(math.pi / 2)
