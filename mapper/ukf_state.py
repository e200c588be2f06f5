"""The layout of the UKF's state (seed 001): which index holds what, and how its yaw wraps.

``x`` = (x_m, y_m, yaw_rad, vx_mps, vy_mps, yaw_rate_radps) in the world frame with body-frame
velocities at the rear axle; with ``UkfConfig.imu_bias_states`` the gyro z and accelerometer
x, y biases follow, then with ``UkfConfig.gnss_heading_state`` the GNSS frame's heading offset
(the last state).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

N_STATE = 6
"""The pose and velocity states."""
N_BIAS = 3
"""The IMU bias states (when estimated)."""
IX, IY, IYAW, IVX, IVY, IW = range(N_STATE)
IBG, IBAX, IBAY = range(N_STATE, N_STATE + N_BIAS)


def wrap_yaw(a: NDArray[np.float64]) -> NDArray[np.float64]:
    """Angles (rad) to [-pi, pi), elementwise: the UKF's wrap of sigma-point deviations."""
    return np.mod(a + math.pi, 2.0 * math.pi) - math.pi
