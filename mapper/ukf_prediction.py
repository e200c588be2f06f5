"""Seed 001's UKF prediction (alg. 2): one unscented step with the IMU's specific force and
yaw rate at the rear axle, and a gap in the IMU's samples driven through in steps (with the
last sample's input held, and its error added, when the IMU has gone silent).

Functions of the :class:`~mapper.ukf_localiser.UkfLocaliser` they move, as :mod:`mapper.ukf_gnss`.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from common.conventions import wrap_angle
from mapper.spd_solve import solve_spd
from mapper.ukf_state import IBAX, IBAY, IBG, IVX, IVY, IW, IX, IY, IYAW, N_STATE, wrap_yaw

if TYPE_CHECKING:
    from mapper.ukf_localiser import UkfLocaliser

MAX_PREDICT_STEPS = 40
"""Most prediction steps over one gap in the IMU's samples (2 s at the default 0.05 s step;
a longer gap, which the health check stops the car for, takes longer steps)."""


def propagate(ukf: UkfLocaliser, ax_mps2: float, ay_mps2: float, gyro_radps: float,
              dt_s: float, held: bool = False) -> None:
    """Predict over ``dt_s`` in steps of at most ``max_predict_dt_s`` (a longer gap is
    driven through, not cut short: the car kept moving), at most MAX_PREDICT_STEPS.
    ``held``: the input is the last sample's, held over a gap, and only a guess: its error,
    as a random walk over each step, widens the yaw rate and the speeds, and the next steps
    carry it into yaw and position (``held_gyro_sigma_radps``, ``held_accel_sigma_mps2``)."""
    cfg = ukf.config
    steps = min(MAX_PREDICT_STEPS, max(1, math.ceil(dt_s / cfg.max_predict_dt_s)))
    step_s = dt_s / steps
    for _ in range(steps):
        predict_input(ukf, ax_mps2, ay_mps2, gyro_radps, step_s)
        if held:
            ukf.P[IW, IW] += cfg.held_gyro_sigma_radps**2 * step_s / cfg.max_predict_dt_s
            q_v = (cfg.held_accel_sigma_mps2 * step_s) ** 2
            ukf.P[IVX, IVX] += q_v
            ukf.P[IVY, IVY] += q_v


def predict_input(ukf: UkfLocaliser, ax_mps2: float, ay_mps2: float, gyro_radps: float,
                  dt_s: float, samples: int = 1) -> None:
    """One unscented prediction step of ``dt_s`` with the rear-axle acceleration and gyro
    (measured; with bias states, each sigma point subtracts its own biases): one IMU sample's,
    or the mean of ``samples`` samples over ``dt_s``, whose white noise is that much smaller
    (the velocity's random walk over ``dt_s`` is the same either way)."""
    cfg = ukf.config
    chi = ukf._sigma_points()
    x, y, yaw, vx, vy, w = chi.T[:N_STATE]
    biased = ukf.nb > 0
    if biased:
        gyro = gyro_radps - chi[:, IBG]
        ax = ax_mps2 - chi[:, IBAX]
        ay = ay_mps2 - chi[:, IBAY]
    else:
        gyro, ax, ay = gyro_radps, ax_mps2, ay_mps2  # type: ignore[assignment]
    c, s = np.cos(yaw), np.sin(yaw)
    nu = cfg.yaw_rate_blend_nu
    out = np.empty_like(chi)
    dvx = (ax + w * vy) * dt_s
    dvy = (ay - w * vx) * dt_s
    # k samples' mean input over dt_s moves the car as k steps of dt_s / k would: the speed
    # gained in the earlier steps carries it on in the later ones ((k - 1) / 2k of dv dt_s)
    carry = (samples - 1) / (2.0 * samples)
    ux = vx + carry * dvx
    uy = vy + carry * dvy
    out[:, IX] = x + (ux * c - uy * s) * dt_s
    out[:, IY] = y + (ux * s + uy * c) * dt_s
    out[:, IVX] = vx + dvx
    out[:, IVY] = vy + dvy
    out[:, IW] = nu * w + (1.0 - nu) * gyro
    # The yaw over the interval with the mean of its two yaw rates (trapezoid): the seed's
    # yaw += w dt with the previous sample's rate lags the yaw by half an IMU period
    # (2.5 ms at 200 Hz: 2 mrad at 1 rad/s, as large as the yaw's sigma).
    out[:, IYAW] = yaw + 0.5 * (w + out[:, IW]) * dt_s
    out[:, N_STATE:] = chi[:, N_STATE:]  # biases and the GNSS heading offset: constant
    mean, cov = ukf._mean_cov(out, (IYAW,))
    if biased:
        # The biases are states: only the white noise (and the unmodelled) is process noise.
        q_acc = (cfg.accel_sigma_mps2**2 * dt_s * dt_s / samples
                 + cfg.accel_model_sigma_mps2**2 * dt_s)
        q_yaw = cfg.yaw_model_sigma_rad_rts**2 * dt_s
    else:
        q_acc = (cfg.accel_sigma_mps2**2 * dt_s / samples + cfg.accel_bias_sigma_mps2**2) * dt_s
        q_yaw = cfg.gyro_bias_sigma_radps**2 * dt_s
    q = [
        1e-6 * dt_s,
        1e-6 * dt_s,
        q_yaw,
        q_acc,
        q_acc + cfg.lateral_model_sigma_mps2**2 * dt_s,
        (1.0 - nu) ** 2 * cfg.gyro_sigma_radps**2 / samples + nu**2 * 1e-4 * dt_s,
    ]
    if biased:
        q += [cfg.gyro_bias_walk_radps_rths**2 * dt_s,
              cfg.accel_bias_walk_mps2_rths**2 * dt_s,
              cfg.accel_bias_walk_mps2_rths**2 * dt_s]
    if ukf.ih is not None:
        q.append(0.0)
    if ukf.PxL is not None:
        # The map errors do not move: their cross-covariance goes through the prediction's
        # statistical linearisation F = P_{x'x} P^-1 (the process noise is independent).
        dx = chi - ukf.x
        dx[:, IYAW] = wrap_yaw(dx[:, IYAW])
        dy = out - mean
        dy[:, IYAW] = wrap_yaw(dy[:, IYAW])
        p_yx = (dy.T * ukf.wc) @ dx
        F = solve_spd(ukf.P, p_yx.T).T
        ukf.PxL = F @ ukf.PxL
    mean[IYAW] = wrap_angle(float(mean[IYAW]))
    ukf.x = mean
    cov.flat[:: ukf.n + 1] += q  # the diagonal
    if cfg.use_odometry and cfg.odometry_scale_sigma > 0.0:
        # The tyre radius is known to a fraction: a systematic along-track speed error that
        # repeated odometry updates cannot average out. Its position effect is spread as an
        # equivalent random walk along the heading over odometry_scale_time_s.
        qa = (cfg.odometry_scale_sigma * float(mean[IVX])) ** 2 * cfg.odometry_scale_time_s
        c, s = math.cos(float(mean[IYAW])), math.sin(float(mean[IYAW]))
        cov[:2, :2] += qa * dt_s * np.array([[c * c, c * s], [c * s, s * s]])
    ukf.P = 0.5 * (cov + cov.T)
