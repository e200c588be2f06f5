"""UKF localisation of seed 001 (KTH): state (x, y, yaw, vx, vy, yaw rate), IMU prediction.

State ``x`` (:mod:`mapper.ukf_state`): world position x_m, y_m, yaw_rad, vehicle-frame velocity
vx_mps (forward), vy_mps (left) at the vehicle origin (rear axle), yaw_rate_radps; covariance
``P`` (n, n).

Prediction (seed 001, algorithm 2) with 2 n + 1 sigma points, vectorised with numpy; the IMU's
specific force is the input. Three corrections to the seed's model: the velocity derivatives
carry the rotating-frame terms (``dvx = ax + w vy``, ``dvy = ay - w vx``; the seed writes
``vy += ay dt`` from vx), the IMU's lever arm ``car.imu_x_m`` is removed (centripetal
``-w^2 r`` on x), and the yaw integrates the mean of the interval's two yaw rates (the seed's
``yaw += w dt`` with the previous rate lags by half an IMU period). The yaw rate follows the
seed's blend ``w = nu w + (1 - nu) gyro``. While the car stands still at the start, the IMU is
averaged for its biases (:mod:`mapper.imu_calibration`) and the state is held at rest.

Optional states after the six: the gyro z and accelerometer x, y biases
(``imu_bias_states``), and the GNSS world frame's heading offset (``gnss_heading_state``, a
constant: :meth:`UkfLocaliser.set_gnss_heading_offset`), which the GNSS course and position
models below carry.

Updates (seed 001, II.B), each switchable (:class:`mapper.config.UkfConfig`) and each with a
Mahalanobis rejection as robot_localization (``*_gate_sigma`` in sigma units; counted in
``stats``):

- odometry: (vx, yaw rate) from the rear wheels (or the steering angle);
- GNSS position and twist (speed, track) (:mod:`mapper.ukf_gnss`);
- cones against a known map in the seed's position form (:mod:`mapper.ukf_cones`);
- a zero lateral speed pseudo-measurement at the rear axle (seed 001: "the lateral speed will be
  assumed to be zero"), at most every 20 ms.

Measurement models other than GNSS velocity are linear in the state; the unscented transform of a
linear function is exact, so those updates use H directly (the same result without sigma points).
"""

from __future__ import annotations

import logging
import math
from collections import Counter
from collections.abc import Callable, Sequence

import numpy as np
from numpy.typing import NDArray

from common.car import CarConfig
from common.conventions import wrap_angle
from common.messages import (
    ConeDetection,
    ConeMap,
    ImuSample,
    PoseEstimate,
    SteeringAngle,
    WheelSpeeds,
)
from mapper import ukf_gnss, ukf_prediction
from mapper.config import UkfConfig
from mapper.imu_calibration import StaticCalibration
from mapper.spd_solve import cho_solve_lower, cholesky_lower, solve_spd
from mapper.ukf_cones import ConeMapUpdate
from mapper.ukf_state import (
    IBAX,
    IBAY,
    IBG,
    IVX,
    IVY,
    IW,
    IX,
    IY,
    IYAW,
    N_BIAS,
    N_STATE,
    wrap_yaw,
)

log = logging.getLogger(__name__)

FloatArray = NDArray[np.float64]


class UkfLocaliser:
    """Seed 001's UKF. ``stats[sensor][outcome]`` counts applied / rejected / skipped updates."""

    def __init__(self, config: UkfConfig, car: CarConfig,
                 initial_pose: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> None:
        self.config = config
        self.car = car
        self.nb = N_BIAS if config.imu_bias_states else 0
        """IMU bias states (0 or 3), at N_STATE ... N_STATE + nb - 1."""
        self.ih: int | None = N_STATE + self.nb if config.gnss_heading_state else None
        """Index of the GNSS heading offset state (rad), or None."""
        self.n = n = N_STATE + self.nb + (1 if self.ih is not None else 0)
        """State size: 6, plus 3 IMU bias states, plus the GNSS heading offset."""
        lam = config.alpha**2 * (n + config.kappa) - n
        self._scale = math.sqrt(n + lam)
        self.wm = np.full(2 * n + 1, 1.0 / (2.0 * (n + lam)))
        self.wc = self.wm.copy()
        self.wm[0] = lam / (n + lam)
        self.wc[0] = self.wm[0] + (1.0 - config.alpha**2 + config.beta)
        self.x = np.zeros(n)
        self.P = np.zeros((n, n))
        self.t_s: float | None = None
        self._last_input: tuple[float, float, float] | None = None
        """The last IMU input propagated (ax, ay, gyro) as :meth:`predict_input` takes them."""
        self._pending_imu = [0.0, 0.0, 0.0, 0.0, 0.0]
        """IMU samples taken together, not yet propagated: span (s), the integrals of ax, ay
        and gyro over it, and how many samples."""
        self._pending_to_s: float | None = None
        """The last of those samples' time (s); None when there are none."""
        self.stats: dict[str, Counter[str]] = {}
        self.gyro_bias_radps = 0.0
        self.accel_bias_mps2 = np.zeros(2)
        self.wheel_scale = config.odometry_speed_scale
        """The wheels' speed scale in use (the configured one, or the Mapper's estimate)."""
        self._odometry_rejected_since_s = math.nan
        """Measurement time (s) of the first of an unbroken run of gated-out wheel speeds."""
        self._calibration = StaticCalibration(config.static_gyro_threshold_radps,
                                              config.static_accel_threshold_mps2)
        self.calibrating = config.static_calibration
        self._cones = ConeMapUpdate()
        self._map: ConeMap | None = None
        self.map_cov: FloatArray | None = None
        """The consider map's error covariance (2 M, 2 M), x0 y0 x1 y1 ... (see :meth:`set_map`)."""
        self.PxL: FloatArray | None = None
        """Cross-covariance (n, 2 M) of the state's error with the consider map's errors."""
        self.reset(initial_pose)

    # -- state --------------------------------------------------------------------------------

    def reset(self, pose: tuple[float, float, float] | PoseEstimate,
              covariance: FloatArray | None = None) -> None:
        """Start again at ``pose`` (x_m, y_m, yaw_rad) or a :class:`PoseEstimate`."""
        cfg = self.config
        n = self.n
        self._last_lateral_s = -math.inf
        self._pending_imu = [0.0, 0.0, 0.0, 0.0, 0.0]
        self._pending_to_s = None
        old_bias = self.x[N_STATE:].copy() if self.x.size == n else np.zeros(n - N_STATE)
        old_bias_p = (self.P[N_STATE:, N_STATE:].copy() if self.P.shape == (n, n)
                      and np.any(self.P[N_STATE:, N_STATE:]) else None)
        self.x = np.zeros(n)
        sig = [cfg.initial_position_sigma_m, cfg.initial_position_sigma_m,
               cfg.initial_yaw_sigma_rad, cfg.initial_velocity_sigma_mps,
               cfg.initial_velocity_sigma_mps, cfg.gyro_sigma_radps]
        if self.nb:
            sig += [cfg.initial_gyro_bias_sigma_radps, cfg.initial_accel_bias_sigma_mps2,
                    cfg.initial_accel_bias_sigma_mps2]
        if self.ih is not None:
            sig.append(cfg.initial_gnss_heading_sigma_rad)
        p = np.diag(np.asarray(sig) ** 2)
        if n > N_STATE:
            # A reset moves the pose; what was learnt about the IMU's biases and the GNSS
            # frame is kept.
            self.x[N_STATE:] = old_bias
            if old_bias_p is not None:
                p[N_STATE:, N_STATE:] = old_bias_p
        if isinstance(pose, PoseEstimate):
            self.x[:N_STATE] = (pose.x_m, pose.y_m, pose.yaw_rad, pose.vx_mps, pose.vy_mps,
                         pose.yaw_rate_radps)
            if np.all(np.isfinite(pose.covariance)) and np.any(pose.covariance):
                p[:3, :3] = pose.covariance
            self.t_s = pose.timestamp_s
        else:
            self.x[:3] = pose
        if covariance is not None:
            c = np.array(covariance, np.float64)
            m = c.shape[0]
            if c.shape != (m, m) or m > n:
                raise ValueError(f"reset: covariance of shape {c.shape} for {n} states")
            p[:m, :m] = c
            if m < n:
                p[:m, m:] = 0.0
                p[m:, :m] = 0.0
        self.P = 0.5 * (p + p.T)
        if self.PxL is not None:
            self.PxL[:] = 0.0  # a fresh pose: its error is independent of the map's

    @property
    def imu_bias(self) -> tuple[float, float, float]:
        """Gyro z (rad/s), accelerometer x and y (m/s^2) biases: the static calibration's plus,
        with ``imu_bias_states``, the estimated states."""
        g = self.gyro_bias_radps
        ax, ay = float(self.accel_bias_mps2[0]), float(self.accel_bias_mps2[1])
        if self.nb:
            g += float(self.x[IBG])
            ax += float(self.x[IBAX])
            ay += float(self.x[IBAY])
        return g, ax, ay

    def set_imu_bias(self, bias: tuple[float, float, float],
                     covariance: FloatArray | None = None) -> None:
        """Take IMU bias estimates (gyro z rad/s, accel x, y m/s^2) from elsewhere (the SLAM at
        the map freeze): into the bias states (with their (3, 3) ``covariance``) when estimated,
        else as the fixed offsets. Ends the static calibration."""
        self.calibrating = False
        if self.nb:
            self.gyro_bias_radps = 0.0
            self.accel_bias_mps2 = np.zeros(2)
            b = slice(N_STATE, N_STATE + self.nb)
            self.x[b] = bias
            if covariance is not None:
                self._set_block(b, 0.5 * (covariance + covariance.T))
        else:
            self.gyro_bias_radps = float(bias[0])
            self.accel_bias_mps2 = np.array([bias[1], bias[2]], np.float64)

    def set_gnss_heading_offset(self, offset_rad: float, sigma_rad: float) -> None:
        """The GNSS world frame's heading error: the world-frame GNSS course reads
        ``yaw + slip + offset`` and the world-frame GNSS position is the true one turned by
        ``offset`` about the start (the frame was estimated with a heading off by -offset).
        Starts the state at ``offset_rad`` with ``sigma_rad``, uncorrelated with the rest; it is
        then estimated as a constant, learnt only where something else fixes the yaw (the
        unmasked cone update; under seed 001's position-only mask it keeps about its prior).
        Without ``gnss_heading_state`` this does nothing."""
        if self.ih is None:
            return
        self.x[self.ih] = offset_rad
        self._set_block(slice(self.ih, self.ih + 1), np.array([[sigma_rad * sigma_rad]]))

    @property
    def gnss_heading_offset(self) -> tuple[float, float]:
        """The GNSS frame's heading offset estimate and its sigma (rad); (0, 0) without the
        state."""
        if self.ih is None:
            return 0.0, 0.0
        return float(self.x[self.ih]), math.sqrt(max(float(self.P[self.ih, self.ih]), 0.0))

    def _set_block(self, block: slice, covariance: FloatArray) -> None:
        """New states in ``block``: their covariance, no correlation with anything else."""
        self.P[block, :] = 0.0
        self.P[:, block] = 0.0
        self.P[block, block] = covariance
        if self.PxL is not None:
            self.PxL[block] = 0.0

    def set_map(self, cone_map: ConeMap | None, covariance: FloatArray | None = None,
                cross_covariance: FloatArray | None = None) -> None:
        """Localise on ``cone_map`` with its errors as *consider* states (Schmidt-Kalman).

        A map's errors are fixed: every sweep sees the same error of the same cones again, so
        adding a cone's covariance to each update's noise (as if fresh) averages them away and
        the pose covariance falls below the pose's true error. Here the map errors
        ``e_L = m_true - m_hat`` are states that are never updated: their covariance
        ``covariance`` (2 M, 2 M), rows x0 y0 x1 y1 ... (default: block diagonal from
        ``cone_map.covariance``, a surveyed map of independent cones), and their
        cross-covariance with this filter's state errors ``cross_covariance`` (n', 2 M), n' <= n
        (default zero; the SLAM hands over its pose-landmark block), are carried along. Cone
        updates on ``cone_map`` then account for the map's error and its correlation over
        cones and time. ``None`` drops the consider map.
        """
        if cone_map is None:
            self._map = self.map_cov = self.PxL = None
            return
        m2 = 2 * len(cone_map)
        if covariance is None:
            cov = np.zeros((m2, m2))
            for i in range(len(cone_map)):
                cov[2 * i:2 * i + 2, 2 * i:2 * i + 2] = cone_map.covariance[i]
        else:
            cov = np.array(covariance, np.float64)
            if cov.shape != (m2, m2):
                raise ValueError(f"set_map: covariance {cov.shape} for {len(cone_map)} cones")
        pxl = np.zeros((self.n, m2))
        if cross_covariance is not None:
            c = np.asarray(cross_covariance, np.float64)
            if c.ndim != 2 or c.shape[1] != m2 or c.shape[0] > self.n:
                raise ValueError(f"set_map: cross-covariance {c.shape} for {self.n} states, "
                                 f"{len(cone_map)} cones")
            pxl[:c.shape[0]] = c
        self._map = cone_map
        self.map_cov = 0.5 * (cov + cov.T)
        self.PxL = pxl
        log.info("UKF localises on %d map cones (consider states): position sigma rms %.4f m, "
                 "pose-map cross-covariance %s", len(cone_map),
                 math.sqrt(float(np.mean(np.diag(cov)))) if m2 else 0.0,
                 "given" if cross_covariance is not None else "zero")

    @property
    def consider_map(self) -> ConeMap | None:
        """The map whose errors are consider states (:meth:`set_map`), or None."""
        return self._map

    def count(self, sensor: str, outcome: str) -> None:
        """Count one measurement's outcome (applied, rejected, skipped_...)."""
        self.stats.setdefault(sensor, Counter())[outcome] += 1

    def pose(self) -> PoseEstimate:
        """The current estimate as a :class:`PoseEstimate` (covariance over x, y, yaw)."""
        x = self.x
        return PoseEstimate(
            timestamp_s=self.t_s if self.t_s is not None else 0.0,
            x_m=float(x[IX]), y_m=float(x[IY]), yaw_rad=wrap_angle(float(x[IYAW])),
            vx_mps=float(x[IVX]), vy_mps=float(x[IVY]), yaw_rate_radps=float(x[IW]),
            covariance=self.P[:3, :3].copy(),
        )

    # -- sigma points -------------------------------------------------------------------------

    def _sigma_points(self) -> FloatArray:
        """(2 n + 1, n) sigma points around x."""
        try:
            s = cholesky_lower(self.P, clean=True)
        except np.linalg.LinAlgError:
            w, v = np.linalg.eigh(0.5 * (self.P + self.P.T))
            s = v * np.sqrt(np.maximum(w, 1e-12))
        s = self._scale * s
        n = self.n
        chi = np.empty((2 * n + 1, n))
        chi[0] = self.x
        chi[1:n + 1] = self.x + s.T
        chi[n + 1:] = self.x - s.T
        return chi

    def _mean_cov(self, chi: FloatArray,
                  angle_cols: Sequence[int]) -> tuple[FloatArray, FloatArray]:
        """Weighted mean and covariance of points (13, m); angles averaged about point 0."""
        dev_ref = chi.copy()
        for c in angle_cols:
            dev_ref[:, c] = chi[0, c] + wrap_yaw(chi[:, c] - chi[0, c])
        mean = self.wm @ dev_ref
        d = dev_ref - mean
        return mean, (d.T * self.wc) @ d

    # -- prediction ---------------------------------------------------------------------------

    def _calibrate(self, imu: ImuSample) -> bool:
        """Static calibration: True while the car still stands (sample absorbed)."""
        if self._calibration.still(imu):
            return True
        self._end_calibration()
        return False

    def _end_calibration(self) -> None:
        """The car moves: the biases are the means of the standstill samples (if enough); with
        bias states these are fixed offsets and the states keep the residual, their variance
        the calibration's standard error."""
        cfg = self.config
        self.calibrating = False
        n = self._calibration.count
        if n < cfg.static_min_samples:
            log.info("IMU static calibration skipped: car moved after %d samples", n)
            return
        mean = self._calibration.mean()
        self.gyro_bias_radps = float(mean[0])
        self.accel_bias_mps2 = mean[1:].copy()
        if self.nb:
            var = self._calibration.variance_of_mean()
            b = slice(N_STATE, N_STATE + self.nb)
            self.x[b] = 0.0
            self._set_block(b, np.diag(var))
        log.info("IMU static calibration from %d samples: gyro bias %.5f rad/s, "
                 "accel bias (%.4f, %.4f) m/s^2", n, self.gyro_bias_radps, *self.accel_bias_mps2)

    def notify_moving(self) -> None:
        """Odometry saw motion: end the static calibration at once."""
        if self.calibrating:
            self._end_calibration()

    def predict(self, imu: ImuSample) -> None:
        """Propagate to ``imu.timestamp_s`` with its specific force and yaw rate (alg. 2;
        :func:`mapper.ukf_prediction.predict_imu`: samples closer than
        ``imu_predict_step_s`` are propagated together)."""
        ukf_prediction.predict_imu(self, imu)

    def _flush_imu(self) -> None:
        """Propagate over the IMU samples held so far (:func:`ukf_prediction.flush_held`)."""
        ukf_prediction.flush_held(self)

    def catch_up(self, timestamp_s: float) -> None:
        """Before a wheel, GNSS or LiDAR update at ``timestamp_s``: the IMU samples taken
        together so far are propagated; when the IMU has been silent for more than
        ``max_predict_dt_s`` before it, propagate to it holding the last IMU sample's input, so
        the update meets the car where it is (and its samples, when they come back late, are
        older than the state and skipped)."""
        self._flush_imu()
        if self.t_s is None or self._last_input is None or self.calibrating:
            return
        dt = timestamp_s - self.t_s
        if not dt > self.config.max_predict_dt_s:  # also NaN
            return
        self.count("imu", "held")
        self._propagate(*self._last_input, dt, held=True)
        self.t_s = timestamp_s

    def _propagate(self, ax_mps2: float, ay_mps2: float, gyro_radps: float, dt_s: float,
                   held: bool = False) -> None:
        ukf_prediction.propagate(self, ax_mps2, ay_mps2, gyro_radps, dt_s, held)

    def predict_input(self, ax_mps2: float, ay_mps2: float, gyro_radps: float, dt_s: float) -> None:
        """One unscented prediction step (:func:`mapper.ukf_prediction.predict_input`)."""
        ukf_prediction.predict_input(self, ax_mps2, ay_mps2, gyro_radps, dt_s)

    # -- updates ------------------------------------------------------------------------------

    def update_linear(self, sensor: str, y: FloatArray, H: FloatArray, R: FloatArray,
                       gate: float, mask: Sequence[int] | None = None) -> bool:
        """Kalman update with innovation ``y`` (m,), ``H`` (m, 6), ``R`` (m, m); Mahalanobis
        gate in sigma units; ``mask`` = state indices the update may change (Joseph form)."""
        P = self.P
        PHt = P @ H.T
        S = H @ PHt + R
        S = 0.5 * (S + S.T)
        try:
            cho = cholesky_lower(S)
        except (np.linalg.LinAlgError, ValueError):
            self.count(sensor, "rejected_singular")
            return False
        Sy = cho_solve_lower(cho, y)
        d2 = float(y @ Sy)
        if not math.isfinite(d2) or d2 > gate * gate:
            self.count(sensor, "rejected")
            return False
        K = cho_solve_lower(cho, PHt.T).T
        if mask is not None:
            keep = np.zeros(self.n, bool)
            keep[list(mask)] = True
            K[~keep] = 0.0
            self.x = self.x + K @ y
            ikh = np.eye(self.n) - K @ H
            P = ikh @ P @ ikh.T + K @ R @ K.T
        else:
            self.x = self.x + K @ y
            P = P - K @ (H @ P)
        if self.PxL is not None:
            self.PxL = self.PxL - K @ (H @ self.PxL)
        self.x[IYAW] = wrap_angle(float(self.x[IYAW]))
        self.P = 0.5 * (P + P.T)
        self.count(sensor, "applied")
        return True

    def update_unscented(self, sensor: str, z: FloatArray,
                          h: Callable[[FloatArray], FloatArray], R: FloatArray,
                          angle_rows: Sequence[int], gate: float) -> bool:
        """Seed 001's unscented update (alg. 1, lines 9-18) for a nonlinear ``h``."""
        chi = self._sigma_points()
        Z = h(chi)
        z_hat, S = self._mean_cov(Z, angle_rows)
        S = S + R
        dx = chi - self.x
        dx[:, IYAW] = wrap_yaw(dx[:, IYAW])
        dz = Z - z_hat
        for r in angle_rows:
            dz[:, r] = wrap_yaw(dz[:, r])
        Pxz = (dx.T * self.wc) @ dz
        y = z - z_hat
        for r in angle_rows:
            y[r] = wrap_angle(float(y[r]))
        try:
            cho = cholesky_lower(S)
        except (np.linalg.LinAlgError, ValueError):
            self.count(sensor, "rejected_singular")
            return False
        d2 = float(y @ cho_solve_lower(cho, y))
        if not math.isfinite(d2) or d2 > gate * gate:
            self.count(sensor, "rejected")
            return False
        K = cho_solve_lower(cho, Pxz.T).T
        if self.PxL is not None:
            # h statistically linearised: H = Pxz^T P^-1.
            H = solve_spd(self.P, Pxz).T
            self.PxL = self.PxL - K @ (H @ self.PxL)
        self.x = self.x + K @ y
        self.x[IYAW] = wrap_angle(float(self.x[IYAW]))
        P = self.P - K @ S @ K.T
        self.P = 0.5 * (P + P.T)
        self.count(sensor, "applied")
        return True

    def update_odometry(self, ws: WheelSpeeds, steer: SteeringAngle | None = None) -> bool:
        """Seed 001's odometry model: z = (vx, yaw rate) from the wheels (and steering)."""
        cfg = self.config
        if not cfg.use_odometry:
            return False
        values = (ws.rear_left_mps, ws.rear_right_mps, ws.front_left_mps, ws.front_right_mps)
        if not all(math.isfinite(v) for v in values):
            self.count("odometry", "rejected_invalid")
            return False
        if self.calibrating and max(abs(v) for v in values) > 0.05:
            self.notify_moving()
        k = self.wheel_scale
        v = ws.mean_rear_mps * k
        source = cfg.odometry_yaw_rate_source
        if source == "steering" and steer is not None and math.isfinite(steer.angle_rad):
            w = v * math.tan(steer.angle_rad) / self.car.wheelbase_m
        elif source == "rear_wheels":
            w = k * (ws.rear_right_mps - ws.rear_left_mps) / self.car.track_width_m
        else:
            w = math.nan
        if math.isfinite(w):
            H = np.zeros((2, self.n))
            H[0, IVX] = 1.0
            H[1, IW] = 1.0
            y = np.array([v - self.x[IVX], w - self.x[IW]])
            R = np.diag([cfg.odometry_speed_sigma_mps**2, cfg.odometry_yaw_rate_sigma_radps**2])
        else:
            H = _row(IVX, self.n)
            y = np.array([v - self.x[IVX]])
            R = np.array([[cfg.odometry_speed_sigma_mps**2]])
        rejected = self.stats.get("odometry", Counter())["rejected"]
        if self.update_linear("odometry", y, H, R, cfg.odometry_gate_sigma):
            self._odometry_rejected_since_s = math.nan
            return True
        if self.stats["odometry"]["rejected"] == rejected:
            return False  # not the gate (a singular innovation)
        t = ws.timestamp_s
        if not math.isfinite(self._odometry_rejected_since_s):
            self._odometry_rejected_since_s = t
        run_s = t - self._odometry_rejected_since_s
        if 0.0 < cfg.odometry_reset_after_s <= run_s:
            self._reset_velocity(y, H, run_s)
            self._odometry_rejected_since_s = math.nan
            return self.update_linear("odometry", y, H, R, cfg.odometry_gate_sigma)
        return False

    def _reset_velocity(self, y: FloatArray, H: FloatArray, run_s: float) -> None:
        """The filter diverged from the wheels (``y``, rows of ``H``: their innovation, gated
        out for ``run_s`` s): forget what it believed of the states the wheels measure (their
        variance becomes the innovation's square, their correlations none) and widen the
        position by what that speed error moved it in ``run_s``."""
        rows = [int(np.flatnonzero(h)[0]) for h in H]
        for i, dy in zip(rows, y, strict=True):
            self.P[i, :] = 0.0
            self.P[:, i] = 0.0
            self.P[i, i] = float(dy) ** 2
            if self.PxL is not None:
                self.PxL[i, :] = 0.0
        drift_m = abs(float(y[0])) * run_s
        self.P[IX, IX] += drift_m**2
        self.P[IY, IY] += drift_m**2
        self.count("odometry", "reset")
        log.warning("UKF: the wheel speeds were gated out for %.2f s (innovation %.2f m/s): "
                    "the speed estimate is reset to the wheels, the position widened by %.2f m",
                    run_s, float(y[0]), drift_m)

    def update_gnss_position(self, xy_world_m: FloatArray, cov: FloatArray | None = None) -> bool:
        """Seed 001's GNSS pose model (:func:`mapper.ukf_gnss.update_position`)."""
        return ukf_gnss.update_position(self, xy_world_m, cov)

    def update_gnss_velocity(self, speed_mps: float, course_world_rad: float,
                             speed_sigma_mps: float | None = None) -> bool:
        """Seed 001's GNSS twist model (:func:`mapper.ukf_gnss.update_velocity`)."""
        return ukf_gnss.update_velocity(self, speed_mps, course_world_rad, speed_sigma_mps)

    def update_cones_on_map(self, cones: Sequence[ConeDetection], cone_map: ConeMap,
                            cones_xy_m: FloatArray | None = None,
                            full_update: bool = False,
                            cone_sigma_m: float | None = None) -> int:
        """Seed 001's cones model against a known map (:mod:`mapper.ukf_cones`); returns how
        many cones were applied.

        ``cones`` are vehicle-frame detections (their positions may be given motion-compensated
        as ``cones_xy_m`` (N, 2)); ``full_update`` also corrects the yaw and the IMU biases;
        ``cone_sigma_m`` overrides the configured detection noise.
        """
        return self._cones.update(self, cones, cone_map, cones_xy_m, full_update, cone_sigma_m)


def _row(i: int, n: int = N_STATE) -> FloatArray:
    h = np.zeros((1, n))
    h[0, i] = 1.0
    return h

