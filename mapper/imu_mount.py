"""The IMU's mounting rotation: its samples turned into the vehicle frame.

An IMU mounted turned against the car (``car.imu_roll_rad``, ``imu_pitch_rad``,
``imu_yaw_rad``; a phone-like device on a windscreen is pitched by a few degrees) reads gravity
and the car's accelerations mixed across its axes. Each sample's specific force (m/s^2) and
angular rate (rad/s) are turned by :func:`common.conventions.mount_rotation`. An IMU mounted
aligned (all three zero, the default) is passed through untouched.
"""

from __future__ import annotations

import numpy as np

from common.car import CarConfig
from common.conventions import mount_rotation
from common.messages import ImuSample


class ImuMount:
    """Turns :class:`ImuSample` s from the IMU's axes into the vehicle's (see the module)."""

    def __init__(self, car: CarConfig) -> None:
        angles = (car.imu_roll_rad, car.imu_pitch_rad, car.imu_yaw_rad)
        self.aligned = all(a == 0.0 for a in angles)
        """True when the IMU is mounted aligned: :meth:`apply` returns samples as they are."""
        self.rotation = mount_rotation(*angles)
        """(3, 3): v_vehicle = rotation @ v_imu."""

    def apply(self, s: ImuSample) -> ImuSample:
        """The sample in the vehicle frame (same time)."""
        if self.aligned:
            return s
        r = self.rotation
        a = r @ np.array([s.accel_x_mps2, s.accel_y_mps2, s.accel_z_mps2])
        g = r @ np.array([s.gyro_x_radps, s.gyro_y_radps, s.gyro_z_radps])
        return ImuSample(s.timestamp_s, float(a[0]), float(a[1]), float(a[2]),
                         float(g[0]), float(g[1]), float(g[2]))
