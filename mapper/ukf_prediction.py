"""Seed 001's UKF prediction (alg. 2): one unscented step with the IMU's specific force and
yaw rate at the rear axle (samples closer than ``imu_predict_step_s`` taken together, issue 42),
the lateral constraint after it, and a gap in the IMU's samples driven through in steps (with
the last sample's input held, and its error added, when the IMU has gone silent).

Functions of the :class:`~mapper.ukf_localiser.UkfLocaliser` they move, as :mod:`mapper.ukf_gnss`.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from common.conventions import wrap_angle
from mapper.motion import rear_slip_velocity
from mapper.spd_solve import solve_spd
from mapper.ukf_state import IBAX, IBAY, IBG, IVX, IVY, IW, IX, IY, IYAW, N_STATE, wrap_yaw

if TYPE_CHECKING:
    from common.messages import ImuSample
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


def predict_imu(ukf: UkfLocaliser, imu: ImuSample) -> None:
    """Propagate ``ukf`` to ``imu.timestamp_s`` with its specific force and yaw rate (alg. 2).

    Samples closer than ``imu_predict_step_s`` are taken together: their inputs are averaged
    and the state propagated once over their span when the span reaches the step (or before
    any update: :meth:`UkfLocaliser.catch_up`). Until then ``ukf.t_s`` stays at the last
    propagation, and the samples after it are the car's to predict with
    (:func:`mapper.motion.predict_forward`)."""
    cfg = ukf.config
    t = imu.timestamp_s
    if ukf.t_s is None:
        ukf.t_s = t
        return
    last_s = ukf._pending_to_s if ukf._pending_to_s is not None else ukf.t_s
    dt = t - last_s
    if not math.isfinite(dt) or dt <= 0.0:
        ukf.count("imu", "skipped_old")
        return
    if ukf.calibrating:
        flush_held(ukf)
        ukf.t_s = t
        if ukf._calibrate(imu):
            ukf.x[IVX:N_STATE] = 0.0
            return
    gz = imu.gyro_z_radps - ukf.gyro_bias_radps
    ax = imu.accel_x_mps2 - float(ukf.accel_bias_mps2[0])
    ay = imu.accel_y_mps2 - float(ukf.accel_bias_mps2[1])
    if cfg.imu_lever_arm:
        # Centripetal term only: the tangential one (dw/dt r) would need a differentiated
        # gyro, noisier than the term itself; vy is held by the lateral constraint anyway.
        # (With bias states: about the mean bias; its spread moves w^2 r negligibly.)
        w = gz - float(ukf.x[IBG]) if ukf.nb else gz
        ax += w * w * ukf.car.imu_x_m
    ukf.count("imu", "applied")
    if dt > cfg.max_predict_dt_s:
        ukf.count("imu", "gap")
        flush_held(ukf)
        dt = t - ukf.t_s
    elif cfg.imu_predict_step_s > 0.0:
        held = ukf._pending_imu
        held[0] += dt
        held[1] += ax * dt
        held[2] += ay * dt
        held[3] += gz * dt
        held[4] += 1.0
        ukf._pending_to_s = t
        if held[0] < cfg.imu_predict_step_s - 1e-9:
            return
        flush_held(ukf)
        _lateral_constraint(ukf, t)
        return
    propagate(ukf, ax, ay, gz, dt)
    ukf.t_s = t
    ukf._last_input = (ax, ay, gz)
    _lateral_constraint(ukf, t)


def flush_held(ukf: UkfLocaliser) -> None:
    """Propagate over the IMU samples taken together so far (their mean input), if any."""
    to_s = ukf._pending_to_s
    if to_s is None:
        return
    span_s, sax, say, sgz, samples = ukf._pending_imu
    mean = (sax / span_s, say / span_s, sgz / span_s)
    ukf._pending_imu = [0.0, 0.0, 0.0, 0.0, 0.0]
    ukf._pending_to_s = None
    predict_input(ukf, *mean, span_s, samples=int(samples))
    ukf.t_s = to_s
    ukf._last_input = mean


def _lateral_constraint(ukf: UkfLocaliser, t: float) -> None:
    """The lateral constraint, at most every 0.02 s, once the state has reached ``t`` (s)."""
    cfg = ukf.config
    if cfg.lateral_velocity_sigma_mps <= 0.0 or t - ukf._last_lateral_s < 0.02:
        return
    ukf._last_lateral_s = t
    # The rear axle slides outwards by its tyres' slip angle k a_y, a_y = vx w:
    # h(x) = vy + k vx^2 w = 0.
    a_max = ukf.car.max_lateral_accel_mps2 if cfg.rear_slip_saturation else math.inf
    vy_slip, d_vx, d_w = rear_slip_velocity(float(ukf.x[IVX]), float(ukf.x[IW]),
                                            cfg.rear_slip_rad_per_mps2, a_max)
    H = np.zeros((1, ukf.n))
    H[0, IVY] = 1.0
    H[0, IVX] = -d_vx
    H[0, IW] = -d_w
    sigma = cfg.lateral_velocity_sigma_mps + cfg.lateral_slip_sigma_fraction * abs(vy_slip)
    ukf.update_linear("lateral", np.array([vy_slip - ukf.x[IVY]]), H,
                      np.array([[sigma**2]]), gate=math.inf)
