"""The models of seed 000's EKF SLAM: the car's motion with the IMU as input (eqs. 5.1-5.3),
the Cartesian observation of a landmark in the vehicle frame (eq. 5.4) and the LiDAR's noise.

State layout (double precision, world frame)::

    x = [x_m, y_m, yaw_rad, vx_mps, vy_mps, (b_gz, b_ax, b_ay,) l0_x_m, l0_y_m, l1_x_m, ...]

The pose is the vehicle origin's (rear axle); ``vx``/``vy`` are WORLD-frame velocities
(eq. 5.3); the IMU biases follow as states when estimated. Landmark ``i`` sits at state
indices ``V + 2 i`` and ``V + 2 i + 1`` (``V`` = 5 or 8 vehicle states).

The seed writes the mid-step heading as ``alpha = theta + T^2/2 * yaw_rate`` (eq. 5.2), which
is dimensionally a typo for ``theta + T/2 * yaw_rate``; ``SlamConfig.heading_mode`` picks one.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from common.conventions import wrap_angle
from mapper.config import SlamConfig

FloatArray = NDArray[np.float64]
POSE_DIM = 5
"""x, y, yaw, vx, vy."""
BIAS_DIM = 3
"""Gyro z bias (rad/s), accelerometer x and y biases (m/s^2), after the pose when estimated."""


def motion_model(
    pose: FloatArray, gyro_radps: float, accel_x_mps2: float, accel_y_mps2: float, dt_s: float,
    heading_factor_s: float,
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Seed 000, eqs. 5.1-5.3: one step of the point-mass model.

    ``pose`` (5,) = x, y, yaw, vx, vy (world); the inputs are the yaw rate (rad/s) and the
    body-frame acceleration of the vehicle origin (m/s^2); ``heading_factor_s`` is the factor of
    the yaw rate in ``alpha = yaw + heading_factor_s * yaw_rate`` (T/2 or the seed's T^2/2).
    Returns the new pose (5,), the Jacobian F (5, 5) with respect to the pose and G (5, 3) with
    respect to the inputs (yaw rate, ax, ay).
    """
    x, y, yaw, vx, vy = pose.tolist()  # Python floats: scalar math on numpy items is slow
    t = dt_s
    h = 0.5 * t * t
    alpha = yaw + heading_factor_s * gyro_radps
    c, s = math.cos(alpha), math.sin(alpha)
    axg = c * accel_x_mps2 - s * accel_y_mps2
    ayg = s * accel_x_mps2 + c * accel_y_mps2
    new = np.array([
        x + t * vx + h * axg,
        y + t * vy + h * ayg,
        wrap_angle(yaw + t * gyro_radps),
        vx + t * axg,
        vy + t * ayg,
    ])
    f = np.array([
        [1.0, 0.0, -h * ayg, t, 0.0],
        [0.0, 1.0, h * axg, 0.0, t],
        [0.0, 0.0, 1.0, 0.0, 0.0],
        [0.0, 0.0, -t * ayg, 1.0, 0.0],
        [0.0, 0.0, t * axg, 0.0, 1.0],
    ])
    k = heading_factor_s
    g = np.array([
        [-h * ayg * k, h * c, -h * s],
        [h * axg * k, h * s, h * c],
        [t, 0.0, 0.0],
        [-t * ayg * k, t * c, -t * s],
        [t * axg * k, t * s, t * c],
    ])
    return new, f, g


def observation_model(
    pose: FloatArray, landmarks_xy_m: FloatArray
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Cartesian observation of landmarks in the vehicle frame: ``z = R(yaw)^T (l - p)``.

    A LiDAR cone detection arrives already in the vehicle frame (the cone detector adds the
    LiDAR's forward offset), so the measurement is Cartesian there. ``pose`` (>= 3,),
    ``landmarks_xy_m`` (M, 2). Returns z (M, 2), the Jacobian with respect to (x, y, yaw)
    (M, 2, 3) and with respect to the landmark (2, 2) (the same for all: R^T).
    """
    c, s = math.cos(pose[2]), math.sin(pose[2])
    d = landmarks_xy_m - pose[:2]
    zx = c * d[:, 0] + s * d[:, 1]
    zy = -s * d[:, 0] + c * d[:, 1]
    m = landmarks_xy_m.shape[0]
    hp = np.empty((m, 2, 3))
    hp[:, 0, 0] = -c
    hp[:, 0, 1] = -s
    hp[:, 0, 2] = zy
    hp[:, 1, 0] = s
    hp[:, 1, 1] = -c
    hp[:, 1, 2] = -zx
    hl = np.array([[c, s], [-s, c]])
    return np.stack([zx, zy], axis=1), hp, hl


def lidar_noise(z: FloatArray, extra_var: FloatArray, lidar_x_m: float,
                cfg: SlamConfig) -> FloatArray:
    """Per-detection noise (k, 2, 2) of vehicle-frame detections ``z`` (k, 2): the LiDAR's
    range and bearing noise about its position ``lidar_x_m`` ahead of the origin (the offset
    of eq. 5.4), rotated into x/y, each axis floored at ``measurement_sigma_floor_m`` (seed
    5.3.5); ``extra_var`` (k,) (m^2) is added to both (motion compensation)."""
    q = z - np.array([lidar_x_m, 0.0])
    rho = np.hypot(q[:, 0], q[:, 1])
    phi = np.arctan2(q[:, 1], q[:, 0])
    floor = cfg.measurement_sigma_floor_m
    var_r = max(cfg.lidar_range_sigma_m, floor) ** 2 + extra_var
    var_t = np.maximum(rho * cfg.lidar_bearing_sigma_rad, floor) ** 2 + extra_var
    cp, sp = np.cos(phi), np.sin(phi)
    r = np.empty((z.shape[0], 2, 2))
    r[:, 0, 0] = cp * cp * var_r + sp * sp * var_t
    r[:, 1, 1] = sp * sp * var_r + cp * cp * var_t
    r[:, 0, 1] = r[:, 1, 0] = cp * sp * (var_r - var_t)
    return r


def inv2(a: FloatArray) -> FloatArray:
    """Inverse of a stack of 2x2 matrices (..., 2, 2)."""
    det = a[..., 0, 0] * a[..., 1, 1] - a[..., 0, 1] * a[..., 1, 0]
    out = np.empty_like(a)
    out[..., 0, 0] = a[..., 1, 1] / det
    out[..., 1, 1] = a[..., 0, 0] / det
    out[..., 0, 1] = -a[..., 0, 1] / det
    out[..., 1, 0] = -a[..., 1, 0] / det
    return out
