"""The car's motion over short times: the lagged state dead-reckoned to now, detections moved to
a common time, and the lateral slide of the rear axle in a corner.

The pose handed to control is the lagged filter's state predicted forward to now with the
buffered IMU samples (:func:`predict_forward`, the mean only: cheap, and the gap is short).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from common.conventions import wrap_angle
from common.messages import ConeDetection, ImuSample

FloatArray = NDArray[np.float64]


def predict_forward(state: FloatArray, t_from_s: float, samples: Sequence[ImuSample],
                    gyro_bias_radps: float, accel_bias_mps2: FloatArray,
                    imu_x_m: float = 0.0) -> tuple[FloatArray, float]:
    """Dead-reckon the mean state (x, y, yaw, vx, vy, yaw rate) (6,) from ``t_from_s`` through
    the IMU ``samples`` newer than it; returns (state (6,), time reached)."""
    x, y, yaw, vx, vy, w = (float(v) for v in state[:6])
    t = t_from_s
    bx = float(accel_bias_mps2[0])
    for s in samples:
        dt = s.timestamp_s - t
        if dt <= 0.0:
            continue
        dt = min(dt, 0.05)
        c, sn = math.cos(yaw), math.sin(yaw)
        x += (vx * c - vy * sn) * dt
        y += (vx * sn + vy * c) * dt
        w_old = w
        w = s.gyro_z_radps - gyro_bias_radps
        yaw += 0.5 * (w_old + w) * dt  # the interval's mean yaw rate, as the filters
        vx += (s.accel_x_mps2 - bx + w * w * imu_x_m + w * vy) * dt
        t = s.timestamp_s
    return np.array([x, y, wrap_angle(yaw), vx, vy, w]), t


def rear_slip_velocity(vx_mps: float, yaw_rate_radps: float, slip_rad_per_mps2: float,
                       max_lateral_accel_mps2: float = math.inf) -> tuple[float, float, float]:
    """Lateral velocity (m/s) of the rear axle in a corner, and its derivatives with respect to
    vx and the yaw rate: ``(vy, d vy / d vx, d vy / d w)``.

    The rear tyres carry their share of the lateral force at a slip angle: for a tyre law
    ``F / Fz = mu tanh(C alpha / mu)`` (C cornering stiffness per load, 1/rad) in a steady
    corner ``F / Fz = a_y / g`` with ``a_y = vx w``, so ``alpha = k a_max atanh(a_y / a_max)``,
    ``k = 1 / (C g)`` (``slip_rad_per_mps2``), ``a_max = mu g`` (the car's lateral limit);
    linear ``alpha = k a_y`` for an infinite ``a_max``. The axle slides outwards at
    ``vy = -vx alpha``.
    """
    k = slip_rad_per_mps2
    if k == 0.0:
        return 0.0, 0.0, 0.0
    ay = vx_mps * yaw_rate_radps
    if math.isfinite(max_lateral_accel_mps2) and max_lateral_accel_mps2 > 0.0:
        a_max = max_lateral_accel_mps2
        u = min(max(ay / a_max, -0.95), 0.95)
        alpha = k * a_max * math.atanh(u)
        gain = k / (1.0 - u * u) if abs(ay / a_max) < 0.95 else 0.0   # d alpha / d a_y
    else:
        alpha = k * ay
        gain = k
    vy = -vx_mps * alpha
    d_vx = -alpha - vx_mps * gain * yaw_rate_radps
    d_w = -vx_mps * gain * vx_mps
    return vy, d_vx, d_w


def rear_slip_from_accel(vx_mps: float, lateral_accel_mps2: float,
                         longitudinal_accel_mps2: float, slip_rad_per_mps2: float,
                         max_lateral_accel_mps2: float) -> tuple[float, float, float, float]:
    """Lateral velocity (m/s) of the rear axle from its measured accelerations, and its
    derivatives with respect to vx, a_y and a_x: ``(vy, d vy / d vx, d vy / d a_y, d vy / d a_x)``.

    As :func:`rear_slip_velocity`, but the tyres' lateral force is read from the rear axle's
    own lateral acceleration ``a_y`` (the accelerometer moved to the axle, m/s^2) instead of the
    steady-state ``vx w``, and the grip left for it is the friction circle's
    ``A = sqrt(a_max^2 - a_x^2)`` (floored at 0.3 ``a_max``), shared with the longitudinal force
    ``a_x`` of driving or braking: ``alpha = k A atanh(a_y / A)``, ``vy = -vx alpha``.

    Why: the rear axle sits near the car's centre of percussion, so its lateral acceleration is
    what its tyres carry, while the slip builds up and decays at a bend's entry and exit as
    well as in the steady corner; ``vx w`` only holds in the steady corner. On the simulated car
    (FSG, an autocross lap) the model's RMS error in the axle's lateral speed is 0.077 m/s from
    ``vx w``, 0.027 m/s from the measured ``a_y`` and 0.012 m/s with the friction circle too.
    """
    k = slip_rad_per_mps2
    if k == 0.0:
        return 0.0, 0.0, 0.0, 0.0
    a_max = max_lateral_accel_mps2
    floor = 0.3 * a_max
    a_sq = a_max * a_max - longitudinal_accel_mps2 * longitudinal_accel_mps2
    if a_sq > floor * floor:
        grip = math.sqrt(a_sq)
        d_grip = -longitudinal_accel_mps2 / grip
    else:
        grip, d_grip = floor, 0.0
    u = lateral_accel_mps2 / grip
    if abs(u) >= 0.95:
        u = math.copysign(0.95, u)
        d_ay, d_u_grip = 0.0, k * math.atanh(u)
    else:
        d_ay = k / (1.0 - u * u)                                  # d alpha / d a_y
        d_u_grip = k * (math.atanh(u) - u / (1.0 - u * u))        # d alpha / d A
    alpha = k * grip * math.atanh(u)
    return (-vx_mps * alpha, -alpha, -vx_mps * d_ay, -vx_mps * d_u_grip * d_grip)


def compensate_motion(cones: Sequence[ConeDetection], t_ref_s: float, vx_mps: float,
                      vy_mps: float, yaw_rate_radps: float) -> FloatArray:
    """Vehicle-frame detections (N, 2) moved to the vehicle frame at ``t_ref_s``.

    A detection seen at ``t`` is a fixed world point; the car moves by (vx, vy, w) over
    ``t_ref_s - t``. Detections already stamped ``t_ref_s`` are unchanged."""
    out = np.empty((len(cones), 2))
    for i, c in enumerate(cones):
        dt = t_ref_s - c.timestamp_s
        if not math.isfinite(dt) or abs(dt) < 1e-4:
            out[i] = (c.x_m, c.y_m)
            continue
        th = yaw_rate_radps * dt
        px, py = c.x_m - vx_mps * dt, c.y_m - vy_mps * dt
        ct, st = math.cos(th), math.sin(th)
        out[i] = (ct * px + st * py, -st * px + ct * py)
    return out
