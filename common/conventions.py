"""Frames, angles and geodetic conversions: one convention everywhere.

- Vehicle frame: x forward, y left, z up, origin at the rear-axle centre on the ground.
- World frame: fixed at the car's start pose (origin at the start position, x along the start
  heading, y to its left).
- Yaw: counter-clockwise from x, wrapped to (-pi, pi].
- Seed 002 (UWA REV) measures bearings clockwise from the y axis and writes its car frame with y
  forward and x to the right; :func:`seed_bearing_to_yaw` and :func:`seed_car_to_world` convert
  at the edge.
- GNSS: WGS84 latitude/longitude (deg) to a local east-north-up frame about a fixed origin
  (the first fix), then into the world frame by the start pose expressed in that ENU frame.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pymap3d
from numpy.typing import ArrayLike, NDArray

TWO_PI = 2.0 * math.pi


def wrap_angle(angle_rad: float) -> float:
    """Wrap an angle to (-pi, pi] (rad)."""
    wrapped = math.fmod(angle_rad + math.pi, TWO_PI)
    if wrapped <= 0.0:
        wrapped += TWO_PI
    return wrapped - math.pi


def wrap_angles(angles_rad: ArrayLike) -> NDArray[np.float64]:
    """Vectorised :func:`wrap_angle`: every element to (-pi, pi]."""
    a = np.asarray(angles_rad, dtype=np.float64)
    wrapped = np.mod(a + math.pi, TWO_PI)
    wrapped = np.where(wrapped <= 0.0, wrapped + TWO_PI, wrapped)
    return wrapped - math.pi


def seed_bearing_to_yaw(bearing_rad: float) -> float:
    """Seed 002's bearing (clockwise from the y axis) to our yaw (counter-clockwise from x)."""
    return wrap_angle(math.pi / 2.0 - bearing_rad)


def yaw_to_seed_bearing(yaw_rad: float) -> float:
    """Our yaw (counter-clockwise from x) to seed 002's bearing (clockwise from y)."""
    return wrap_angle(math.pi / 2.0 - yaw_rad)


def compass_deg_to_enu_yaw(course_deg: float) -> float:
    """A compass course (deg clockwise from north, as NMEA) to an ENU yaw (rad, CCW from east)."""
    return wrap_angle(math.radians(90.0 - course_deg))


def enu_yaw_to_compass_deg(yaw_rad: float) -> float:
    """An ENU yaw (rad, CCW from east) to a compass course (deg clockwise from north), [0, 360)."""
    return (90.0 - math.degrees(yaw_rad)) % 360.0


def seed_car_to_world(
    x_car_m: float, y_car_m: float, car_x_m: float, car_y_m: float, car_bearing_rad: float
) -> tuple[float, float]:
    """Seed 002, section 7.2, literally: an object in the seed's car frame to the seed's world.

    The seed's car frame has y forward and x to the right; its bearing is clockwise from y.
    Returns the object's (x, y) in the seed's world frame. Kept so that the seed's formulas are
    tested against ours (:func:`vehicle_to_world`); use ours everywhere else.
    """
    distance_m = math.hypot(x_car_m, y_car_m)
    bearing_rad = math.atan2(x_car_m, y_car_m) + car_bearing_rad
    return (
        distance_m * math.sin(bearing_rad) + car_x_m,
        distance_m * math.cos(bearing_rad) + car_y_m,
    )


def vehicle_to_world(
    points_xy_m: ArrayLike, pose_x_m: float, pose_y_m: float, pose_yaw_rad: float
) -> NDArray[np.float64]:
    """Vehicle-frame points (N, 2) or (2,) to the world frame, given the car's pose."""
    p = np.asarray(points_xy_m, dtype=np.float64)
    c, s = math.cos(pose_yaw_rad), math.sin(pose_yaw_rad)
    x = p[..., 0] * c - p[..., 1] * s + pose_x_m
    y = p[..., 0] * s + p[..., 1] * c + pose_y_m
    return np.stack([x, y], axis=-1)


def world_to_vehicle(
    points_xy_m: ArrayLike, pose_x_m: float, pose_y_m: float, pose_yaw_rad: float
) -> NDArray[np.float64]:
    """World-frame points (N, 2) or (2,) into the vehicle frame of a car at the given pose."""
    p = np.asarray(points_xy_m, dtype=np.float64)
    dx = p[..., 0] - pose_x_m
    dy = p[..., 1] - pose_y_m
    c, s = math.cos(pose_yaw_rad), math.sin(pose_yaw_rad)
    return np.stack([dx * c + dy * s, -dx * s + dy * c], axis=-1)


@dataclass(frozen=True, slots=True)
class LocalTangentFrame:
    """A local east-north-up frame about a WGS84 origin (deg, deg, m)."""

    lat0_deg: float
    lon0_deg: float
    alt0_m: float = 0.0

    def to_enu(
        self, lat_deg: ArrayLike, lon_deg: ArrayLike, alt_m: ArrayLike = 0.0
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """WGS84 to east, north, up (m) about the origin (pymap3d, ellipsoid WGS84)."""
        e, n, u = pymap3d.geodetic2enu(lat_deg, lon_deg, alt_m, self.lat0_deg, self.lon0_deg,
                                       self.alt0_m)
        return np.asarray(e, np.float64), np.asarray(n, np.float64), np.asarray(u, np.float64)

    def to_geodetic(
        self, east_m: ArrayLike, north_m: ArrayLike, up_m: ArrayLike = 0.0
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """East, north, up (m) about the origin back to WGS84 latitude, longitude (deg), height."""
        lat, lon, alt = pymap3d.enu2geodetic(east_m, north_m, up_m, self.lat0_deg, self.lon0_deg,
                                             self.alt0_m)
        return np.asarray(lat, np.float64), np.asarray(lon, np.float64), np.asarray(alt, np.float64)


@dataclass(frozen=True, slots=True)
class WorldFrame:
    """The world frame: the start pose expressed in a local ENU frame.

    ``start_east_m``, ``start_north_m`` is the start position in ``enu``; ``start_yaw_enu_rad``
    the start heading there (CCW from east). World x lies along that heading.
    """

    enu: LocalTangentFrame
    start_east_m: float = 0.0
    start_north_m: float = 0.0
    start_yaw_enu_rad: float = 0.0

    def enu_to_world(self, east_m: ArrayLike, north_m: ArrayLike) -> NDArray[np.float64]:
        """ENU (m) to world (m), (..., 2)."""
        en = np.stack([np.asarray(east_m, np.float64), np.asarray(north_m, np.float64)], axis=-1)
        return world_to_vehicle(en, self.start_east_m, self.start_north_m, self.start_yaw_enu_rad)

    def world_to_enu(self, points_xy_m: ArrayLike) -> NDArray[np.float64]:
        """World (m) to ENU east, north (m), (..., 2)."""
        return vehicle_to_world(points_xy_m, self.start_east_m, self.start_north_m,
                                self.start_yaw_enu_rad)

    def geodetic_to_world(self, lat_deg: ArrayLike, lon_deg: ArrayLike) -> NDArray[np.float64]:
        """WGS84 latitude, longitude (deg) to world x, y (m), (..., 2); height ignored."""
        e, n, _ = self.enu.to_enu(lat_deg, lon_deg, self.enu.alt0_m)
        return self.enu_to_world(e, n)

    def world_to_geodetic(self, points_xy_m: ArrayLike) -> tuple[NDArray, NDArray]:  # type: ignore[type-arg]
        """World x, y (m) to WGS84 latitude, longitude (deg) at the origin's height."""
        en = self.world_to_enu(points_xy_m)
        lat, lon, _ = self.enu.to_geodetic(en[..., 0], en[..., 1], 0.0)
        return lat, lon

    def enu_yaw_to_world_yaw(self, yaw_enu_rad: float) -> float:
        """A heading in ENU (CCW from east) to a world yaw."""
        return wrap_angle(yaw_enu_rad - self.start_yaw_enu_rad)

    def world_yaw_to_enu_yaw(self, yaw_rad: float) -> float:
        """A world yaw to a heading in ENU (CCW from east)."""
        return wrap_angle(yaw_rad + self.start_yaw_enu_rad)


def mount_rotation(roll_rad: float, pitch_rad: float, yaw_rad: float) -> NDArray[np.float64]:
    """The rotation (3, 3) taking a sensor's axes to the vehicle's for a sensor mounted turned
    by roll, pitch, yaw (rad; about x, then y, then z of the vehicle frame, z up):
    ``R_z(yaw) R_y(pitch) R_x(roll)``; ``v_vehicle = R @ v_sensor``."""
    cr, sr = math.cos(roll_rad), math.sin(roll_rad)
    cp, sp = math.cos(pitch_rad), math.sin(pitch_rad)
    cy, sy = math.cos(yaw_rad), math.sin(yaw_rad)
    rx = np.array([[1.0, 0.0, 0.0], [0.0, cr, -sr], [0.0, sr, cr]])
    ry = np.array([[cp, 0.0, sp], [0.0, 1.0, 0.0], [-sp, 0.0, cp]])
    rz = np.array([[cy, -sy, 0.0], [sy, cy, 0.0], [0.0, 0.0, 1.0]])
    return np.asarray(rz @ ry @ rx, np.float64)
