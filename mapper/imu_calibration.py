"""The IMU's static calibration: while the car stands still at the start, the mean of the IMU
samples is its gyro z and accelerometer x, y biases (gravity is along z)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from common.messages import ImuSample

FloatArray = NDArray[np.float64]


class StaticCalibration:
    """Collects IMU samples until one says the car moves: a gyro z rate more than
    ``gyro_threshold_radps`` or a horizontal specific force more than ``accel_threshold_mps2``
    away from the mean so far (the first sample's value before any)."""

    def __init__(self, gyro_threshold_radps: float, accel_threshold_mps2: float) -> None:
        self.gyro_threshold_radps = gyro_threshold_radps
        self.accel_threshold_mps2 = accel_threshold_mps2
        self._sum = np.zeros(3)
        self._sq = np.zeros(3)
        self.count = 0
        """Samples taken (the car standing)."""
        self._ref: FloatArray | None = None

    def still(self, imu: ImuSample) -> bool:
        """Take the sample if the car still stands (True); False (sample not taken) once it
        moves."""
        v = np.array([imu.gyro_z_radps, imu.accel_x_mps2, imu.accel_y_mps2])
        if self._ref is None:
            self._ref = v.copy()
        mean = self._sum / self.count if self.count else self._ref
        moving = (abs(v[0] - mean[0]) > self.gyro_threshold_radps
                  or float(np.hypot(v[1] - mean[1], v[2] - mean[2]))
                  > self.accel_threshold_mps2)
        if moving:
            return False
        self._sum += v
        self._sq += v * v
        self.count += 1
        return True

    def mean(self) -> FloatArray:
        """The samples' mean (3,): gyro z (rad/s), accelerometer x, y (m/s^2); needs samples."""
        return self._sum / self.count

    def variance_of_mean(self) -> FloatArray:
        """The squared standard error of :meth:`mean` (3,) (at least 1e-12 / count)."""
        n = self.count
        mean = self._sum / n
        return np.maximum(self._sq / n - mean * mean, 1e-12) / n
