"""EKF SLAM with cones as landmarks (seed 000, section 5.3), with controlled loop closure.

State (double precision), world frame::

    x = [x_m, y_m, yaw_rad, vx_mps, vy_mps, (b_gz, b_ax, b_ay,) l0_x_m, l0_y_m, l1_x_m, ...]

The pose is that of the vehicle origin (rear axle); ``vx``/``vy`` are WORLD-frame velocities
(seed 000, eq. 5.3). With ``SlamConfig.imu_bias_states`` (default) the gyro z and accelerometer
x, y biases follow as states (random walks; the IMU input is measurement minus bias): the car
may drive off without a standstill to calibrate them, and an uncorrected 0.002 rad/s gyro bias
turns the map by 0.08 rad over a lap. ``V`` = 5 or 8 vehicle states; landmark ``i`` sits at state
indices ``V + 2 i`` and ``V + 2 i + 1``.

Models
------
- Prediction (eqs. 5.1-5.3) with the IMU as input: the body-frame specific force (x, y only:
  gravity is along z) is moved from the IMU mount (``car.imu_x_m``) to the rear axle, rotated into
  the world frame by ``alpha`` and integrated by the point-mass model; the yaw integrates the gyro.
  The seed writes ``alpha = theta + T^2/2 * yaw_rate`` (eq. 5.2), which is dimensionally a typo
  for the mid-step heading ``theta + T/2 * yaw_rate``; ``SlamConfig.heading_mode`` picks one
  ("midpoint", the default, or "seed" literally). Process noise ``Q = G diag(s_g^2, s_a^2,
  s_a^2) / T G^T`` from the IMU noise densities. The covariance is propagated in block form
  (eq. 5.8): only the pose block changes at each IMU sample; the pose-landmark cross block is
  multiplied by the accumulated pose Jacobian lazily, once before the next update, so a
  prediction costs O(1) and a flush O(N) in the number of landmarks.
- Observation (eq. 5.4): a LiDAR cone detection arrives already in the vehicle frame (the cone
  detector adds the LiDAR's forward offset ``car.lidar_x_m``), so the measurement is CARTESIAN in
  the vehicle frame, ``z = R(yaw)^T (l - p)``. The LiDAR offset enters the noise: the sensor's
  range/bearing noise (``lidar_range_sigma_m``, ``lidar_bearing_sigma_rad``) is taken about the
  LiDAR's position and rotated into x/y, each axis floored at ``measurement_sigma_floor_m``
  (seed 5.3.5). Cones stamped before their sweep's timestamp are moved to it with the estimated
  velocity and yaw rate (adding ``motion_compensation_sigma_mps * dt`` of noise), so a whole sweep
  is ONE batched update (seed 5.3 discusses the equivalence).
- Update: ``P <- P - K (H P)`` without an explicit inverse: with ``S = L L^T`` (Cholesky,
  LAPACK ``dpotrf``), ``K (H P) = V V^T`` with ``V = (H P)^T L^-T`` (BLAS ``dtrsm``) and
  ``K y = V (L^-1 y)``; ``H`` is used only on the columns it touches. ``V V^T`` is subtracted
  by ``dsyrk`` in place on the lower triangle of ``P`` (:mod:`mapper.slam_blas`); the upper
  triangle of the landmark block is then stale and mirrored from the lower one before anyone
  reads the whole ``P`` (the ``P`` property, the loop closure), so ``P`` is exactly symmetric
  wherever it is read and the lower triangle is the one truth (the triangles cannot drift).
- Association: Mahalanobis distance with a chi-square gate (``gate_probability``, 2 dof), then a
  global assignment per sweep (``scipy.optimize.linear_sum_assignment``), beyond the seed
  (its future work 6.2.4). Landmarks not seen for ``unseen_travel_m`` of travel are not
  associated (seed 5.3.2) until the loop is closed.
- Preliminary landmark list (seed 5.3.3): an unassociated detection becomes a landmark only when
  seen again (within ``preliminary_gate_m``) in the next sweep.
- Controlled loop closure (seed 5.3.2): after ``min_lap_distance_m`` of travel, new big orange
  cones (size LARGE or colour BIG_ORANGE) are paired with the old ones by a translation-consistent
  pattern match; each pair is merged by a "same point" measurement ``l_old - l_new = 0`` with a
  tiny noise floor ``same_point_sigma_m`` (the seed uses none; the floor keeps S positive
  definite) and the new landmark is deleted. A backward sweep over the landmarks, newest first,
  then merges every duplicate (close in Euclidean and Mahalanobis distance to a landmark that was
  never seen at the same time).
- Wheel odometry: the rear axle's forward speed (mean of the rear wheels, which read
  ``vx (1 + wheel_slip_per_mps2 a_x)``: the tyres' longitudinal slip) and a lateral
  pseudo-measurement: the rear axle slides outwards only by its tyres' slip angle in a corner
  (:func:`mapper.fusion.rear_slip_velocity`; zero slip is the plain non-holonomic
  constraint); the yaw rate is an input (gyro), not a state, so the steering angle is not
  needed. GPS: world-frame position with its covariance,
  Mahalanobis-gated.
"""

from __future__ import annotations

import logging
import math
from collections import Counter
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray
from scipy.linalg.blas import dtrsm, dtrsv
from scipy.linalg.lapack import dpotrf, dpotrs
from scipy.optimize import linear_sum_assignment
from scipy.stats import chi2

from common.car import CarConfig
from common.conventions import wrap_angle
from common.messages import (
    ConeColour,
    ConeDetection,
    ConeMap,
    ConeSize,
    ImuSample,
    PoseEstimate,
    SteeringAngle,
    WheelSpeeds,
)
from mapper.config import MapperConfig
from mapper.fusion import rear_slip_velocity
from mapper.slam_blas import mirror_lower, syrk_lower_inplace

log = logging.getLogger(__name__)

FloatArray = NDArray[np.float64]
POSE_DIM = 5
"""x, y, yaw, vx, vy."""
BIAS_DIM = 3
"""Gyro z bias (rad/s), accelerometer x and y biases (m/s^2), after the pose when estimated."""
_N_COLOURS = len(ConeColour)
_N_SIZES = len(ConeSize)
_BIG = 1.0e9
_SYMMETRISE_EVERY = 50
"""Updates between explicit symmetrisations when the update runs in numpy (the BLAS path keeps
the lower triangle as the only truth, so the triangles cannot drift apart)."""


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

    ``pose`` (>= 3,), ``landmarks_xy_m`` (M, 2). Returns z (M, 2), the Jacobian with respect to
    (x, y, yaw) (M, 2, 3) and with respect to the landmark (2, 2) (the same for all: R^T).
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


def _inv2(a: FloatArray) -> FloatArray:
    """Inverse of a stack of 2x2 matrices (..., 2, 2)."""
    det = a[..., 0, 0] * a[..., 1, 1] - a[..., 0, 1] * a[..., 1, 0]
    out = np.empty_like(a)
    out[..., 0, 0] = a[..., 1, 1] / det
    out[..., 1, 1] = a[..., 0, 0] / det
    out[..., 0, 1] = -a[..., 0, 1] / det
    out[..., 1, 0] = -a[..., 1, 0] / det
    return out


class EkfSlam:
    """EKF SLAM core (see the module docstring for the models).

    ``x`` is the state (5 + 2 N,), ``P`` its covariance; ``loop_closed`` says whether the
    controlled loop closure has happened. ``stats`` counts events and rejections by name.
    """

    def __init__(self, config: MapperConfig, car: CarConfig) -> None:
        self.cfg = config.slam
        self.car = car
        c = self.cfg
        self._gate = float(chi2.ppf(c.gate_probability, 2))
        self._new_gate = float(chi2.ppf(c.new_landmark_probability, 2))
        self._merge_gate = float(chi2.ppf(c.merge_gate_probability, 2))
        self._gps_gate = float(chi2.ppf(c.gps_gate_probability, 2))
        self._heading_seed = c.heading_mode == "seed"
        self._pd = POSE_DIM + (BIAS_DIM if c.imu_bias_states else 0)
        """Vehicle states before the landmarks: the pose (5) and, when estimated, the biases."""
        cap = self._pd + 2 * 64
        self._xbuf = np.zeros(cap)
        self._pbuf = np.zeros((cap, cap))
        self._n = self._pd
        self._pbuf[:self._pd, :self._pd] = np.diag(self._initial_vehicle_variances())
        self._reset_lazy()
        self._lower_only = False
        """The strict upper triangle of the landmark block ``P[V:, V:]`` is stale: the lower
        triangle is the covariance there (see :meth:`_update`); :meth:`_mirror` restores it."""
        self._scratch = np.empty(0)
        self._q_input = np.array([c.gyro_noise_density_radps_rthz, c.accel_noise_density_mps2_rthz,
                                  c.accel_noise_density_mps2_rthz]) ** 2
        """Input noise densities squared; divided by the step for Q (seed 000)."""
        self._q_walk = np.array([c.gyro_bias_walk_radps_rths, c.accel_bias_walk_mps2_rths,
                                 c.accel_bias_walk_mps2_rths]) ** 2
        self._bias_diag = (POSE_DIM + BIAS_DIM + 1) * np.arange(POSE_DIM, POSE_DIM + BIAS_DIM)
        self._cone_index: dict[int, tuple[NDArray[np.int64], ...]] = {}
        """Index arrays of the batched cone update by number of detections (_cone_structure)."""
        self._vehicle_upper = np.triu(np.ones((POSE_DIM + BIAS_DIM,) * 2, bool), 1)
        """Strict upper triangle of the largest vehicle block (8, 8)."""
        """Flat indices of the bias states' diagonal in the (8, 8) vehicle block."""
        # Per-landmark bookkeeping, one row per landmark.
        self._ids = np.zeros(0, np.int64)
        self._first_seen_m = np.zeros(0)
        self._last_seen_m = np.zeros(0)
        self._colour_votes = np.zeros((0, _N_COLOURS))
        self._size_votes = np.zeros((0, _N_SIZES))
        self._next_id = 0
        # Preliminary list (seed 5.3.3): world xy (K, 2) and size of the previous sweep's
        # unassociated detections.
        self._prelim_xy = np.zeros((0, 2))
        self._prelim_size = np.zeros(0, np.int64)
        self._prelim_colour = np.zeros(0, np.int64)
        self.t_s: float | None = None
        self.odometer_m = 0.0
        self._last_imu: ImuSample | None = None
        self._input = (0.0, 0.0, 0.0, 0.0)
        """Last IMU input: yaw rate, specific force x, y, yaw acceleration (held between
        samples); see :meth:`_corrected_input`."""
        self.loop_closed = False
        self.loop_closure_odometer_m = math.nan
        self.merged_on_closure = 0
        self.stats: Counter[str] = Counter()
        self._updates = 0

    # ----------------------------------------------------------------------------------------
    # State access
    # ----------------------------------------------------------------------------------------

    @property
    def x(self) -> FloatArray:
        """The state vector (V + 2 N,), a view (landmark means brought up to date)."""
        self._flush_mean()
        return self._xbuf[: self._n]

    @property
    def P(self) -> FloatArray:  # noqa: N802 (the conventional name)
        """The covariance (V + 2 N, V + 2 N), exactly symmetric, a view (cross blocks brought up
        to date) valid until the next update."""
        self._flush()
        self._mirror()
        return self._pbuf[: self._n, : self._n]

    @property
    def n_landmarks(self) -> int:
        """Number of landmarks in the filter."""
        return (self._n - self._pd) // 2

    @property
    def landmarks_xy_m(self) -> FloatArray:
        """Landmark positions (N, 2), world frame (a copy)."""
        self._flush_mean()
        return self._xbuf[self._pd: self._n].reshape(-1, 2).copy()

    @property
    def preliminary_xy_m(self) -> FloatArray:
        """The preliminary landmark list (K, 2), world frame."""
        return self._prelim_xy.copy()

    def _initial_vehicle_variances(self) -> FloatArray:
        c = self.cfg
        sig = [c.initial_position_sigma_m, c.initial_position_sigma_m, c.initial_yaw_sigma_rad,
               c.initial_velocity_sigma_mps, c.initial_velocity_sigma_mps]
        if self._pd > POSE_DIM:
            sig += [c.initial_gyro_bias_sigma_radps, c.initial_accel_bias_sigma_mps2,
                    c.initial_accel_bias_sigma_mps2]
        return np.asarray(sig, np.float64) ** 2

    @property
    def vehicle_dim(self) -> int:
        """Number of vehicle states before the landmarks: 5 (pose) or 8 (pose and IMU biases)."""
        return self._pd

    @property
    def imu_bias(self) -> tuple[float, float, float]:
        """Estimated gyro z (rad/s), accelerometer x and y (m/s^2) biases (zero if not states)."""
        if self._pd == POSE_DIM:
            return 0.0, 0.0, 0.0
        return float(self._xbuf[5]), float(self._xbuf[6]), float(self._xbuf[7])

    def load_state(self, x: FloatArray, p: FloatArray, timestamp_s: float = 0.0) -> None:
        """Replace the state (V + 2 N,) and covariance; landmarks get fresh ids, seen now.

        ``V`` is 5 (the pose, an odd-sized state: the IMU biases are then not estimated) or 8
        (pose and biases, even-sized). For tests and benchmarks (and restoring a saved filter).
        """
        x = np.asarray(x, np.float64).reshape(-1)
        p = np.asarray(p, np.float64)
        n = x.size
        self._pd = POSE_DIM if n % 2 else POSE_DIM + BIAS_DIM
        if n < self._pd or (n - self._pd) % 2 or p.shape != (n, n):
            raise ValueError(f"load_state: bad shapes x {x.shape}, P {p.shape}")
        cap = max(self._xbuf.size, n)
        self._xbuf = np.zeros(cap)
        self._pbuf = np.zeros((cap, cap))
        self._xbuf[:n] = x
        self._pbuf[:n, :n] = p
        self._n = n
        self._reset_lazy()
        self._lower_only = False
        m = self.n_landmarks
        self._ids = np.arange(m, dtype=np.int64)
        self._next_id = m
        self._first_seen_m = np.full(m, self.odometer_m)
        self._last_seen_m = np.full(m, self.odometer_m)
        self._colour_votes = np.zeros((m, _N_COLOURS))
        self._size_votes = np.zeros((m, _N_SIZES))
        self.t_s = timestamp_s

    def update_landmarks(self, z: FloatArray, r: FloatArray, landmarks: NDArray[np.int64]
                         ) -> bool:
        """The batched update for KNOWN associations: detections ``z`` (a, 2) in the vehicle
        frame at the filter's time, noise ``r`` (a, 2, 2), landmark indices (a,)."""
        self._flush()
        return self._apply_cone_update(np.asarray(z, np.float64).reshape(-1, 2),
                                       np.asarray(r, np.float64).reshape(-1, 2, 2),
                                       np.asarray(landmarks, np.int64).reshape(-1))

    def _reset_lazy(self) -> None:
        v = self._pd
        self._f_full = np.eye(v)
        """The vehicle block's prediction Jacobian, reused: identity but for its first rows."""
        self._f_acc = np.eye(v)
        self._f_pending = False
        self._lazy_b = np.zeros((v, v))
        self._lazy_c = np.zeros(v)
        self._b_pending = False
        self._c_pending = False

    def _flush_mean(self) -> None:
        """Apply the pending vehicle-only updates to the landmark means: ``x_L += P_Lv0 c``."""
        if not self._c_pending:
            return
        v, n = self._pd, self._n
        if n > v:
            self._xbuf[v:n] += self._lazy_c @ self._pbuf[:v, v:n]
        self._lazy_c = np.zeros(v)
        self._c_pending = False

    def _flush(self) -> None:
        """Bring the landmark blocks up to date (eq. 5.8 and the compressed updates).

        Predictions and updates that touch only the vehicle states (odometry, GPS) change the
        vehicle block at once and leave the landmarks to this: with ``P_vL0``, ``P_LL0``,
        ``x_L0`` as they were at the last flush, the cross block is ``M P_vL0`` (``M`` the
        product of the prediction Jacobians and the updates' ``I - K_v H``), the landmark block
        ``P_LL0 - P_Lv0 B P_vL0`` and the means ``x_L0 + P_Lv0 c`` (``B``, ``c`` summed over the
        updates). Exact, and O(V) per update instead of O(N^2) (Guivant and Nebot's compressed
        filter)."""
        self._flush_mean()
        if not (self._f_pending or self._b_pending):
            return
        v, n = self._pd, self._n
        if n > v:
            p = self._pbuf
            cross0 = p[:v, v:n]
            if self._b_pending:
                bc = self._lazy_b @ cross0
                p[v:n, v:n] -= cross0.T @ bc
                # Not exactly symmetric in floating point: the lower triangle is the truth.
                self._lower_only = True
            cross = self._f_acc @ cross0 if self._f_pending else cross0.copy()
            p[:v, v:n] = cross
            p[v:n, :v] = cross.T
        self._f_acc = np.eye(v)
        self._f_pending = False
        self._lazy_b = np.zeros((v, v))
        self._b_pending = False

    # ----------------------------------------------------------------------------------------
    # Prediction
    # ----------------------------------------------------------------------------------------

    def predict(self, imu: ImuSample) -> None:
        """Propagate the state to ``imu.timestamp_s`` with the IMU as input (seed 5.1-5.3).

        The input over the interval is the mean of the previous and this sample (trapezoid).
        Samples that are not finite or not newer than the filter are counted and skipped.
        """
        values = (imu.gyro_z_radps, imu.accel_x_mps2, imu.accel_y_mps2)
        if not all(math.isfinite(v) for v in values) or not math.isfinite(imu.timestamp_s):
            self.stats["imu_rejected_nonfinite"] += 1
            return
        prev = self._last_imu
        if self.t_s is None or prev is None:
            self._last_imu = imu
            self._input = self._origin_input(imu, imu, 0.0)
            if self.t_s is None:
                self.t_s = imu.timestamp_s
            return
        dt = imu.timestamp_s - self.t_s
        dt_samples = imu.timestamp_s - prev.timestamp_s
        if dt < 0.0 or dt_samples <= 0.0:
            self.stats["imu_rejected_old"] += 1
            return
        if dt > self.cfg.max_predict_dt_s:
            self.stats["imu_gap"] += 1
        if dt == 0.0:
            # Another measurement at this very time moved the filter here already (with the
            # held input): the sample still sets the input for what follows.
            self._input = self._origin_input(prev, imu, dt_samples)
            self._last_imu = imu
            return
        self._input = self._origin_input(prev, imu, dt_samples)
        self._last_imu = imu
        self._propagate(dt)
        self.t_s = imu.timestamp_s

    def predict_to(self, timestamp_s: float) -> None:
        """Propagate to ``timestamp_s`` holding the last IMU input (no-op if not newer)."""
        if self.t_s is None:
            self.t_s = timestamp_s
            return
        dt = timestamp_s - self.t_s
        if dt <= 0.0:
            return
        self._propagate(dt)
        self.t_s = timestamp_s

    def _origin_input(self, prev: ImuSample, cur: ImuSample, dt_s: float
                      ) -> tuple[float, float, float, float]:
        """The IMU's mean yaw rate, specific force x, y over the interval (trapezoid) and the
        differenced yaw acceleration; biases and the lever arm are applied in
        :meth:`_corrected_input`."""
        w = 0.5 * (prev.gyro_z_radps + cur.gyro_z_radps)
        ax = 0.5 * (prev.accel_x_mps2 + cur.accel_x_mps2)
        ay = 0.5 * (prev.accel_y_mps2 + cur.accel_y_mps2)
        w_dot = (cur.gyro_z_radps - prev.gyro_z_radps) / dt_s if dt_s > 0.0 else 0.0
        return w, ax, ay, w_dot

    def _corrected_input(self) -> tuple[float, float, float]:
        """Yaw rate and body acceleration of the vehicle origin: the IMU input less the
        estimated biases, moved from the IMU mount to the origin.

        The IMU at ``car.imu_x_m`` ahead of the origin measures ``a_o + w_dot x r + w x (w x r)``;
        the differenced gyro for ``w_dot`` telescopes in the integrated velocity, so its noise
        does not accumulate.
        """
        w, ax, ay, w_dot = self._input
        if self._pd > POSE_DIM:
            w -= float(self._xbuf[5])
            ax -= float(self._xbuf[6])
            ay -= float(self._xbuf[7])
        if self.cfg.imu_lever_arm and self.car.imu_x_m != 0.0:
            r = self.car.imu_x_m
            ax += w * w * r
            ay -= w_dot * r
        return w, ax, ay

    def _propagate(self, dt: float) -> None:
        w, ax, ay = self._corrected_input()
        k = 0.5 * dt * dt if self._heading_seed else 0.5 * dt
        pd = self._pd
        pose = self._xbuf[:POSE_DIM]
        speed_mps = math.hypot(float(pose[3]), float(pose[4]))
        new, f5, g = motion_model(pose, w, ax, ay, dt, k)
        self.odometer_m += dt * speed_mps
        self._xbuf[:POSE_DIM] = new
        q_u = self._q_input / dt
        pxx = self._pbuf[:pd, :pd]
        if pd == POSE_DIM:
            f = f5
            new_pxx = f @ pxx @ f.T + (g * q_u) @ g.T
        else:
            # The inputs are (measurement - bias): d new / d bias = -G (lever-arm terms of the
            # gyro bias neglected: w^2 r changes by 2 w r b, far below the noise).
            f = self._f_full                                   # identity outside these
            f[:POSE_DIM, :POSE_DIM] = f5
            np.negative(g, out=f[:POSE_DIM, POSE_DIM:])
            new_pxx = f @ pxx @ f.T
            new_pxx[:POSE_DIM, :POSE_DIM] += (g * q_u) @ g.T
            new_pxx.flat[self._bias_diag] += self._q_walk * dt
        pxx[...] = new_pxx
        pxx += new_pxx.T
        pxx *= 0.5
        self._f_acc = f @ self._f_acc
        self._f_pending = True

    # ----------------------------------------------------------------------------------------
    # Generic sparse update
    # ----------------------------------------------------------------------------------------

    def _update(self, cols: NDArray[np.int64], h: FloatArray, innovation: FloatArray,
                r: FloatArray) -> bool:
        """EKF update with ``H`` non-zero only on the state columns ``cols``.

        ``h`` (k, len(cols)) is that part of H, ``innovation`` (k,) = z - h(x), ``r`` (k, k).
        ``P <- P - K (H P)`` with Cholesky solves; returns False (counted) if S is not positive
        definite.

        With ``S = L L^T``, ``K (H P) = V V^T`` where ``V = (H P)^T L^-T`` (n, k): one BLAS
        ``dsyrk`` subtracts it from the LOWER triangle of P in place (half the multiply-adds of
        the full product, no (n, n) temporary; :func:`mapper.slam_blas.syrk_lower_inplace`).
        The vehicle rows are then mirrored at once (V of them); the upper triangle of the
        landmark block stays stale (``_lower_only``) until someone needs the whole matrix
        (:meth:`_mirror`: the ``P`` property, the loop closure). Readers of landmark rows take
        them from the lower triangle (the rows below: :meth:`_rows`).
        """
        self._flush()
        n = self._n
        p = self._pbuf[:n, :n]
        hp = h @ self._rows(cols)                              # (k, n) = H P
        s = hp[:, cols] @ h.T + r
        # S = L L^T (LAPACK directly: scipy's cho_factor/cho_solve cost more in argument
        # checking than the 40 x 40 factorisation).
        chol, info = dpotrf(s, lower=1, clean=0, overwrite_a=1)
        if info != 0:
            self.stats["update_not_positive_definite"] += 1
            log.warning("EKF SLAM update skipped: S not positive definite")
            return False
        # V = (H P)^T L^-T: one BLAS triangular solve with the Cholesky factor, (n, k), in
        # place of H P (no longer needed); K y = (H P)^T S^-1 y = V (L^-1 y).
        vt = dtrsm(1.0, chol, hp.T, side=1, lower=1, trans_a=1, overwrite_b=1)
        self._xbuf[:n] += vt @ dtrsv(chol, innovation, lower=1)
        if syrk_lower_inplace(p, vt):
            v = min(self._pd, n)
            pvv = p[:v, :v]
            np.copyto(pvv, pvv.T.copy(), where=self._vehicle_upper[:v, :v])
            p[:v, v:] = p[v:, :v].T
            self._lower_only = n > v
        else:
            # No BLAS reachable: the full product (numpy calls syrk and mirrors it, exactly
            # symmetric) into a buffer kept between updates (a fresh one is page-faulted in on
            # every update: 3 ms instead of 0.5 at n 600).
            if self._scratch.size < n * n:
                self._scratch = np.empty(max(n * n, 2 * self._scratch.size))
            vvt = self._scratch[:n * n].reshape(n, n)
            np.matmul(vt, vt.T, out=vvt)
            p -= vvt
            self._updates += 1
            if self._updates % _SYMMETRISE_EVERY == 0:
                self._symmetrise()
        self._xbuf[2] = wrap_angle(float(self._xbuf[2]))
        return True

    def _rows(self, cols: NDArray[np.int64]) -> FloatArray:
        """Rows ``cols`` of the (symmetric) covariance (k, n), a new array: with a stale upper
        triangle (``_lower_only``) the part right of the diagonal comes from the column."""
        n = self._n
        p = self._pbuf[:n, :n]
        rows = p[cols, :]
        if self._lower_only:
            c_min = int(cols.min()) if cols.size else n
            part = rows[:, c_min:]
            np.copyto(part, p[c_min:, cols].T,
                      where=np.arange(c_min, n)[None, :] > cols[:, None])
        return rows

    def _mirror(self) -> None:
        """Make P exactly symmetric again from its lower triangle if the upper one is stale."""
        if self._lower_only:
            v = self._pd
            mirror_lower(self._pbuf[v: self._n, v: self._n])
            self._lower_only = False

    def _update_vehicle(self, cols: NDArray[np.int64], h: FloatArray, innovation: FloatArray,
                        r: FloatArray) -> bool:
        """EKF update whose ``H`` touches only vehicle states (``cols`` < V): the vehicle block
        now, the landmarks lazily (see :meth:`_flush`)."""
        v = self._pd
        hv = np.zeros((h.shape[0], v))
        hv[:, cols] = h
        pvv = self._pbuf[:v, :v]
        hp = hv @ pvv                                          # (k, V)
        s = hp @ hv.T + r
        # LAPACK directly (cho_factor/cho_solve add ~20 us of checks to a 2 x 2 solve, and
        # this runs at the odometry rate)
        chol, info = dpotrf(s, lower=1, clean=0, overwrite_a=1)
        if info != 0:
            self.stats["update_not_positive_definite"] += 1
            log.warning("EKF SLAM update skipped: S not positive definite")
            return False
        rhs = np.empty((s.shape[0], 2 * v + 1), order="F")
        rhs[:, :v] = hv
        rhs[:, v:2 * v] = hp
        rhs[:, 2 * v] = innovation
        sol, info = dpotrs(chol, rhs, lower=1, overwrite_b=1)  # one solve for all three
        s_inv_h = sol[:, :v]                                   # S^-1 H (k, V)
        kt = sol[:, v:2 * v]                                   # K^T = S^-1 H P_vv (k, V)
        s_inv_y = sol[:, 2 * v]
        self._xbuf[:v] += hp.T @ s_inv_y
        new_pvv = pvv - hp.T @ kt
        self._pbuf[:v, :v] = 0.5 * (new_pvv + new_pvv.T)
        if self._n > v:
            m = self._f_acc
            hm = hv @ m                                        # H M (k, V)
            self._lazy_c += hm.T @ s_inv_y
            self._lazy_b += hm.T @ (s_inv_h @ m)
            self._f_acc = m - kt.T @ hm                        # (I - K_v H) M
            self._f_pending = self._b_pending = self._c_pending = True
        self._xbuf[2] = wrap_angle(float(self._xbuf[2]))
        return True

    def _symmetrise(self) -> None:
        """Make P exactly symmetric: from the lower triangle if the upper one is stale, else
        ``P = (P + P^T) / 2`` (the rank-k update is symmetric already; this guards round-off)."""
        if self._lower_only:
            self._mirror()
            return
        p = self._pbuf[: self._n, : self._n]
        p[...] = 0.5 * (p + p.T)

    # ----------------------------------------------------------------------------------------
    # Odometry and GPS
    # ----------------------------------------------------------------------------------------

    def update_odometry(self, ws: WheelSpeeds, steer: SteeringAngle | None = None) -> None:
        """Wheel odometry: the rear axle's forward speed and its lateral velocity.

        The lateral velocity of the rear axle is not zero in a corner: the rear tyres run at a
        slip angle ``alpha = rear_slip_rad_per_mps2 * a_y`` (their cornering stiffness), so the
        axle slides outwards at ``vy = -vx * alpha``, ``a_y = vx * w``. The pseudo-measurement is
        ``vy = vy_slip(vx, w)`` (:func:`mapper.fusion.rear_slip_velocity`; a zero
        ``rear_slip_rad_per_mps2`` gives the plain non-holonomic constraint), its noise growing
        with the slip (``lateral_slip_sigma_fraction``). ``steer`` is accepted for the
        interface but not needed (the yaw rate is the gyro's). The driven or braked rear
        tyres slip: the wheels read ``vx (1 + k a_x)`` with ``a_x`` the axle's longitudinal
        acceleration (the IMU input less its bias; ``k`` = ``wheel_slip_per_mps2``).
        """
        del steer
        if not self.cfg.use_odometry:
            return
        v = ws.mean_rear_mps
        if not math.isfinite(v) or not math.isfinite(ws.timestamp_s):
            self.stats["odometry_rejected_nonfinite"] += 1
            return
        self.predict_to(ws.timestamp_s)
        _, _, yaw, vx, vy = self._xbuf[:POSE_DIM]
        c, s = math.cos(yaw), math.sin(yaw)
        vxb, vyb = c * vx + s * vy, -s * vx + c * vy
        w, ax, _ = self._corrected_input()
        a_max = (self.car.max_lateral_accel_mps2 if self.cfg.rear_slip_saturation
                 else math.inf)
        vy_slip, d_vx, d_w = rear_slip_velocity(vxb, w, self.cfg.rear_slip_rad_per_mps2, a_max)
        # Longitudinal slip: the driven / braked rear tyres turn faster / slower than the axle
        # moves, by a fraction proportional to the longitudinal force (a_x of the axle).
        k = self.cfg.wheel_slip_per_mps2
        scale = 1.0 + k * ax
        # d vxb / d (yaw, vx, vy) and d vyb / d (yaw, vx, vy)
        dvxb = np.array([vyb, c, s])
        dvyb = np.array([-vxb, -s, c])
        biased = self._pd > POSE_DIM
        h = np.zeros((2, 5 if biased else 3))
        h[0, :3] = scale * dvxb
        h[1, :3] = dvyb - d_vx * dvxb
        if biased:
            h[1, 3] = d_w                    # w = gyro - bias
            h[0, 4] = -k * vxb               # a_x = accel - bias
            if self.cfg.imu_lever_arm:       # a_x has w^2 r from the lever arm
                h[0, 3] = -2.0 * k * vxb * w * self.car.imu_x_m
        pred = np.array([scale * vxb, vyb - vy_slip])
        lat_sigma = (self.cfg.lateral_velocity_sigma_mps
                     + self.cfg.lateral_slip_sigma_fraction * abs(vy_slip))
        r = np.diag([self.cfg.wheel_speed_sigma_mps ** 2
                     + (self.cfg.wheel_speed_sigma_fraction * vxb) ** 2, lat_sigma ** 2])
        cols = np.array([2, 3, 4, 5, 6]) if biased else np.array([2, 3, 4])
        self._update_vehicle(cols, h, np.array([v, 0.0]) - pred, r)
        self.stats["odometry_updates"] += 1

    def update_gps_xy(self, xy_world_m: FloatArray, cov: FloatArray,
                      timestamp_s: float | None = None) -> bool:
        """GPS position (2,) in the world frame with covariance (2, 2); Mahalanobis-gated.

        Returns True when applied.
        """
        if not self.cfg.use_gps:
            return False
        z = np.asarray(xy_world_m, np.float64).reshape(2)
        r = np.asarray(cov, np.float64).reshape(2, 2)
        if not (np.all(np.isfinite(z)) and np.all(np.isfinite(r))):
            self.stats["gps_rejected_nonfinite"] += 1
            return False
        if timestamp_s is not None:
            self.predict_to(timestamp_s)
        r = 0.5 * (r + r.T) + np.eye(2) * self.cfg.measurement_sigma_floor_m ** 2
        y = z - self._xbuf[:2]
        s = self._pbuf[:2, :2] + r
        d2 = float(y @ np.linalg.solve(s, y))
        if d2 > self._gps_gate:
            self.stats["gps_rejected_gate"] += 1
            return False
        ok = self._update_vehicle(np.array([0, 1]), np.eye(2), y, r)
        self.stats["gps_updates"] += int(ok)
        return ok

    # ----------------------------------------------------------------------------------------
    # Cones
    # ----------------------------------------------------------------------------------------

    def _measurement_noise(self, z: FloatArray, extra_var: FloatArray) -> FloatArray:
        """Per-detection noise (k, 2, 2) in the vehicle frame: LiDAR polar noise about the
        LiDAR's position (the offset of eq. 5.4), floored per axis (seed 5.3.5)."""
        c = self.cfg
        q = z - np.array([self.car.lidar_x_m, 0.0])
        rho = np.hypot(q[:, 0], q[:, 1])
        phi = np.arctan2(q[:, 1], q[:, 0])
        floor = c.measurement_sigma_floor_m
        var_r = max(c.lidar_range_sigma_m, floor) ** 2 + extra_var
        var_t = np.maximum(rho * c.lidar_bearing_sigma_rad, floor) ** 2 + extra_var
        cp, sp = np.cos(phi), np.sin(phi)
        r = np.empty((z.shape[0], 2, 2))
        r[:, 0, 0] = cp * cp * var_r + sp * sp * var_t
        r[:, 1, 1] = sp * sp * var_r + cp * cp * var_t
        r[:, 0, 1] = r[:, 1, 0] = cp * sp * (var_r - var_t)
        return r

    def _landmark_blocks(self, idx: NDArray[np.int64]) -> tuple[FloatArray, FloatArray]:
        """Cross covariances pose(3)-landmark (M, 3, 2) and landmark blocks (M, 2, 2)."""
        p = self._pbuf
        c0 = self._pd + 2 * idx
        ppl = np.stack([p[:3, c0].T, p[:3, c0 + 1].T], axis=2)
        pll = np.empty((idx.size, 2, 2))
        pll[:, 0, 0] = p[c0, c0]
        pll[:, 0, 1] = pll[:, 1, 0] = p[c0 + 1, c0]          # the lower triangle: see _update
        pll[:, 1, 1] = p[c0 + 1, c0 + 1]
        return ppl, pll

    def _active_mask(self) -> NDArray[np.bool_]:
        """Landmarks that may be associated (seed 5.3.2: recently seen, or all after closure)."""
        if self.loop_closed and self.cfg.associate_all_after_closure:
            return np.ones(self.n_landmarks, bool)
        return (self.odometer_m - self._last_seen_m) <= self.cfg.unseen_travel_m

    def update_cones(self, cones: Sequence[ConeDetection], timestamp_s: float) -> int:
        """One LiDAR sweep: associate, one batched update, then the preliminary list.

        ``cones`` are in the vehicle frame, each at its own ``timestamp_s`` (moved to the sweep's
        ``timestamp_s``). Returns the number of detections associated with landmarks.
        """
        c = self.cfg
        if not math.isfinite(timestamp_s):
            self.stats["sweep_rejected_nonfinite"] += 1
            return 0
        self.predict_to(timestamp_s)
        self._flush()
        self.stats["sweeps"] += 1
        if not cones:
            self._prelim_xy = np.zeros((0, 2))
            return 0
        raw = np.array([(d.x_m, d.y_m, d.timestamp_s) for d in cones], np.float64)
        sizes = np.array([int(d.size) for d in cones], np.int64)
        colours = np.array([int(d.colour) for d in cones], np.int64)
        z = raw[:, :2]
        ok = np.all(np.isfinite(raw), axis=1) & (np.hypot(z[:, 0], z[:, 1]) <= c.max_range_m)
        ok &= (sizes >= 0) & (sizes < _N_SIZES) & (colours >= 0) & (colours < _N_COLOURS)
        if not np.all(ok):
            self.stats["cones_rejected"] += int(np.count_nonzero(~ok))
            raw, z, sizes, colours = raw[ok], z[ok], sizes[ok], colours[ok]
            if raw.shape[0] == 0:
                return 0
        # Move each detection to the sweep timestamp with the estimated motion.
        dt = timestamp_s - raw[:, 2]
        extra = (c.motion_compensation_sigma_mps * dt) ** 2
        if np.any(dt != 0.0):
            yaw, vxw, vyw = self._xbuf[2], self._xbuf[3], self._xbuf[4]
            cy, sy = math.cos(yaw), math.sin(yaw)
            vb = np.array([cy * vxw + sy * vyw, -sy * vxw + cy * vyw])
            # z_T = R(-w dt) z_i - R(-w dt / 2) v_body dt (the car moved along an arc).
            ang = self._corrected_input()[0] * dt
            ca, sa = np.cos(ang), np.sin(ang)
            ch, sh = np.cos(0.5 * ang), np.sin(0.5 * ang)
            z = np.stack([ca * z[:, 0] + sa * z[:, 1] - dt * (ch * vb[0] + sh * vb[1]),
                          -sa * z[:, 0] + ca * z[:, 1] - dt * (-sh * vb[0] + ch * vb[1])],
                         axis=1)
        r_all = self._measurement_noise(z, extra)

        n_det = z.shape[0]
        assigned_det = np.zeros(0, np.int64)
        assigned_lm = np.zeros(0, np.int64)
        near_any = np.zeros(n_det, bool)
        m = self.n_landmarks
        if m:
            lm_xy = self._xbuf[self._pd: self._n].reshape(-1, 2)
            reach = c.max_range_m + 3.0
            dist = np.hypot(lm_xy[:, 0] - self._xbuf[0], lm_xy[:, 1] - self._xbuf[1])
            cand = np.flatnonzero(self._active_mask() & (dist <= reach))
            if cand.size:
                zhat, hp, hl = observation_model(self._xbuf[:3], lm_xy[cand])
                ppl, pll = self._landmark_blocks(cand)
                ppp = self._pbuf[:3, :3]
                hpp = np.einsum("mij,jk,mlk->mil", hp, ppp, hp)
                cross = np.einsum("mij,mjk,lk->mil", hp, ppl, hl)
                spred = hpp + cross + cross.transpose(0, 2, 1) + hl @ pll @ hl.T
                y = z[:, None, :] - zhat[None, :, :]                     # (k, m, 2)
                s_pair = spred[None, :, :, :] + r_all[:, None, :, :]
                d2 = np.einsum("kmi,kmij,kmj->km", y, _inv2(s_pair), y)
                near_any = np.min(d2, axis=1) <= self._new_gate
                eucl = np.hypot(y[..., 0], y[..., 1])
                near_any |= np.min(eucl, axis=1) < c.new_landmark_min_distance_m
                cost = np.where(d2 <= self._gate, d2, _BIG)
                rows, cols = linear_sum_assignment(cost)
                good = cost[rows, cols] < _BIG
                assigned_det, assigned_lm = rows[good], cand[cols[good]]
                if assigned_det.size:
                    self._apply_cone_update(z[assigned_det], r_all[assigned_det], assigned_lm)
                    self._last_seen_m[assigned_lm] = self.odometer_m
                    self._size_votes[assigned_lm, sizes[assigned_det]] += 1.0
                    self._colour_votes[assigned_lm, colours[assigned_det]] += 1.0
        self.stats["cones_associated"] += int(assigned_det.size)
        free = np.ones(n_det, bool)
        free[assigned_det] = False
        free &= ~near_any
        self.stats["cones_ambiguous"] += int(n_det - assigned_det.size - np.count_nonzero(free))
        self._preliminary(z[free], r_all[free], sizes[free], colours[free])
        if not self.loop_closed:
            self.try_close_loop()
        return int(assigned_det.size)

    def _apply_cone_update(self, z: FloatArray, r: FloatArray, lm: NDArray[np.int64]) -> bool:
        """One batched update for detections ``z`` (a, 2) of landmarks ``lm`` (a,).

        The model is :func:`observation_model`'s, written out with as few array operations as
        possible (a sweep's update is dominated by per-call overhead apart from the rank-k
        product): ``H`` (2a, 3 + 2a) on the columns ``x, y, yaw`` and the landmarks' is
        ``[-R^T | R^T (-dy, dx)... | blockdiag(R^T)]`` (see :meth:`_cone_structure`).
        """
        a = lm.size
        pd = self._pd
        xb = self._xbuf
        yaw = float(xb[2])
        c, s = math.cos(yaw), math.sin(yaw)
        hl = np.array([[c, s], [-s, c]])                       # R^T, d z / d l
        cols, pose_idx, yaw_idx, rr_idx = self._cone_structure(a)
        lm_cols = cols[3::2]
        np.add(2 * lm, pd, out=lm_cols)
        np.add(lm_cols, 1, out=cols[4::2])
        zhat = (xb[cols[3:]].reshape(a, 2) - xb[:2]) @ hl.T      # (a, 2) = R^T (l - p)
        h = np.zeros((2 * a, 3 + 2 * a))
        h.put(pose_idx, np.concatenate([-hl.ravel(), hl.ravel()]))  # d/d(x, y) and d/dl
        h.put(yaw_idx, zhat[:, ::-1] * (1.0, -1.0))            # d/d yaw = (zy, -zx)
        rr = np.zeros((2 * a, 2 * a))
        rr.put(rr_idx, r)                                      # blockdiag(r)
        return self._update(cols, h, (z - zhat).ravel(), rr)

    def _cone_structure(self, a: int) -> tuple[NDArray[np.int64], NDArray[np.int64],
                                               NDArray[np.int64], NDArray[np.int64]]:
        """Index arrays of a batched cone update with ``a`` detections, cached by ``a``.

        Returns the state columns (3 + 2a,) (a fresh array: the pose columns set, the
        landmarks' to fill), the flat indices in H (2a, 3 + 2a) of the x, y and landmark
        entries (8 per detection: row 2i: x, y, then row 2i + 1: x, y, then the same for the
        2 x 2 landmark block, in the order ``put`` repeats its 8 values), those of the yaw
        column (2a,) and of the 2 x 2 blocks of blockdiag(R) (2a, 2a) (4 per detection).
        """
        cached = self._cone_index.get(a)
        if cached is None:
            m = 3 + 2 * a
            i = np.arange(a)[:, None]
            row0, row1 = 2 * i * m, (2 * i + 1) * m
            lm0 = 3 + 2 * i
            pose_idx = np.concatenate([row0, row0 + 1, row1, row1 + 1, row0 + lm0,
                                       row0 + lm0 + 1, row1 + lm0, row1 + lm0 + 1], axis=1)
            yaw_idx = np.concatenate([row0 + 2, row1 + 2], axis=1)
            q = 2 * a
            rr_idx = np.concatenate([2 * i * q + 2 * i, 2 * i * q + 2 * i + 1,
                                     (2 * i + 1) * q + 2 * i, (2 * i + 1) * q + 2 * i + 1],
                                    axis=1)
            cols0 = np.zeros(m, np.int64)
            cols0[:3] = (0, 1, 2)
            cached = (cols0, pose_idx.ravel(), yaw_idx.ravel(), rr_idx.ravel())
            self._cone_index[a] = cached
        return cached[0].copy(), cached[1], cached[2], cached[3]

    def _preliminary(self, z: FloatArray, r: FloatArray, sizes: NDArray[np.int64],
                     colours: NDArray[np.int64]) -> None:
        """Seed 5.3.3: promote detections seen again since the previous sweep; keep the rest."""
        yaw = float(self._xbuf[2])
        cy, sy = math.cos(yaw), math.sin(yaw)
        rot = np.array([[cy, -sy], [sy, cy]])
        world = self._xbuf[:2] + z @ rot.T
        promote = np.zeros(z.shape[0], bool)
        if self._prelim_xy.shape[0] and z.shape[0]:
            d = np.hypot(world[:, None, 0] - self._prelim_xy[None, :, 0],
                         world[:, None, 1] - self._prelim_xy[None, :, 1])
            cost = np.where(d <= self.cfg.preliminary_gate_m, d, _BIG)
            rows, cols = linear_sum_assignment(cost)
            good = cost[rows, cols] < _BIG
            ri, ci = rows[good], cols[good]
            promote[ri] = True
            sizes[ri] = np.where(sizes[ri] == 0, self._prelim_size[ci], sizes[ri])
            colours[ri] = np.where(colours[ri] == 0, self._prelim_colour[ci], colours[ri])
        if np.any(promote):
            self._add_landmarks(z[promote], r[promote], sizes[promote], colours[promote])
        self._prelim_xy = world[~promote]
        self._prelim_size = sizes[~promote]
        self._prelim_colour = colours[~promote]

    def _add_landmarks(self, z: FloatArray, r: FloatArray, sizes: NDArray[np.int64],
                       colours: NDArray[np.int64]) -> None:
        """State augmentation: ``l = p + R(yaw) z`` with its covariance and cross terms."""
        self._flush()
        a = z.shape[0]
        n = self._n
        n_new = n + 2 * a
        if n_new > self._xbuf.size:
            cap = max(2 * self._xbuf.size, n_new)
            xbuf = np.zeros(cap)
            xbuf[:n] = self._xbuf[:n]
            pbuf = np.zeros((cap, cap))
            pbuf[:n, :n] = self._pbuf[:n, :n]
            self._xbuf, self._pbuf = xbuf, pbuf
        yaw = float(self._xbuf[2])
        cy, sy = math.cos(yaw), math.sin(yaw)
        rot = np.array([[cy, -sy], [sy, cy]])
        w = z @ rot.T                                            # (a, 2) rotated offsets
        g = np.zeros((a, 2, 3))
        g[:, 0, 0] = 1.0
        g[:, 1, 1] = 1.0
        g[:, 0, 2] = -w[:, 1]
        g[:, 1, 2] = w[:, 0]
        g2 = g.reshape(2 * a, 3)
        p = self._pbuf
        self._xbuf[n:n_new] = (self._xbuf[:2] + w).ravel()
        cross = g2 @ p[:3, :n]                                   # (2a, n)
        p[n:n_new, :n] = cross
        p[:n, n:n_new] = cross.T
        block = g2 @ p[:3, :3] @ g2.T
        rw = rot @ r @ rot.T                                     # (a, 2, 2)
        bi = 2 * np.arange(a)
        for i in range(2):
            for j in range(2):
                block[bi + i, bi + j] += rw[:, i, j]
        p[n:n_new, n:n_new] = 0.5 * (block + block.T)
        self._n = n_new
        self._ids = np.concatenate([self._ids, np.arange(self._next_id, self._next_id + a)])
        self._next_id += a
        now = np.full(a, self.odometer_m)
        self._first_seen_m = np.concatenate([self._first_seen_m, now])
        self._last_seen_m = np.concatenate([self._last_seen_m, now])
        votes_s = np.zeros((a, _N_SIZES))
        votes_s[np.arange(a), sizes] = 1.0
        votes_c = np.zeros((a, _N_COLOURS))
        votes_c[np.arange(a), colours] = 1.0
        self._size_votes = np.concatenate([self._size_votes, votes_s])
        self._colour_votes = np.concatenate([self._colour_votes, votes_c])
        self.stats["landmarks_added"] += a

    def _delete_landmarks(self, lm: NDArray[np.int64]) -> None:
        """Remove landmarks ``lm`` (their rows and columns) from the filter."""
        self._flush()
        n = self._n
        keep_lm = np.ones(self.n_landmarks, bool)
        keep_lm[lm] = False
        keep = np.concatenate([np.ones(self._pd, bool), np.repeat(keep_lm, 2)])
        idx = np.flatnonzero(keep)
        x = self._xbuf[:n][idx]
        p = self._pbuf[:n, :n][np.ix_(idx, idx)]
        n_new = idx.size
        self._xbuf[:n_new] = x
        self._pbuf[:n_new, :n_new] = p
        self._n = n_new
        for name in ("_ids", "_first_seen_m", "_last_seen_m", "_colour_votes", "_size_votes"):
            setattr(self, name, getattr(self, name)[keep_lm])
        self.stats["landmarks_deleted"] += int(lm.size)

    # ----------------------------------------------------------------------------------------
    # Colour
    # ----------------------------------------------------------------------------------------

    def add_colour_votes(self, cones: Sequence[ConeDetection], pose: PoseEstimate | None = None
                         ) -> int:
        """Camera cones (vehicle frame at ``pose``; default the current estimate) vote for the
        colour of the nearest landmark within ``colour_gate_m`` (world frame), weighted by their
        confidence. Returns the number of votes cast."""
        m = self.n_landmarks
        if not cones or m == 0:
            return 0
        self._flush_mean()
        px, py, yaw = ((pose.x_m, pose.y_m, pose.yaw_rad) if pose is not None
                       else tuple(float(v) for v in self._xbuf[:3]))
        arr = np.array([(d.x_m, d.y_m, int(d.colour), d.confidence) for d in cones], np.float64)
        arr = arr[np.all(np.isfinite(arr), axis=1)]
        colours = arr[:, 2].astype(np.int64)
        keep = (colours > int(ConeColour.UNKNOWN)) & (colours < _N_COLOURS)
        arr, colours = arr[keep], colours[keep]
        if arr.shape[0] == 0:
            return 0
        cy, sy = math.cos(yaw), math.sin(yaw)
        wx = px + cy * arr[:, 0] - sy * arr[:, 1]
        wy = py + sy * arr[:, 0] + cy * arr[:, 1]
        lm = self._xbuf[self._pd: self._n].reshape(-1, 2)
        d = np.hypot(wx[:, None] - lm[None, :, 0], wy[:, None] - lm[None, :, 1])
        cost = np.where(d <= self.cfg.colour_gate_m, d, _BIG)
        rows, cols = linear_sum_assignment(cost)
        good = cost[rows, cols] < _BIG
        np.add.at(self._colour_votes, (cols[good], colours[rows[good]]),
                  np.clip(arr[rows[good], 3], 0.0, 1.0))
        return int(np.count_nonzero(good))

    def _colours(self) -> NDArray[np.int64]:
        votes = self._colour_votes[:, 1:]
        out = np.argmax(votes, axis=1) + 1
        out[np.max(votes, axis=1) <= 0.0] = int(ConeColour.UNKNOWN)
        return out.astype(np.int64)

    def _sizes(self) -> NDArray[np.int64]:
        votes = self._size_votes[:, 1:]
        out = np.argmax(votes, axis=1) + 1
        out[np.max(votes, axis=1) <= 0.0] = int(ConeSize.UNKNOWN)
        return out.astype(np.int64)

    def _big_mask(self) -> NDArray[np.bool_]:
        """Landmarks that are big orange cones: size LARGE or colour BIG_ORANGE by vote, with
        at least ``min_big_cone_votes`` votes for it."""
        n = self.cfg.min_big_cone_votes
        large = (self._sizes() == int(ConeSize.LARGE)) & (
            self._size_votes[:, int(ConeSize.LARGE)] >= n)
        orange = (self._colours() == int(ConeColour.BIG_ORANGE)) & (
            self._colour_votes[:, int(ConeColour.BIG_ORANGE)] >= n)
        return large | orange

    # ----------------------------------------------------------------------------------------
    # Loop closure
    # ----------------------------------------------------------------------------------------

    def try_close_loop(self) -> bool:
        """Controlled loop closure (seed 5.3.2); True once the loop is closed.

        Tried after ``min_lap_distance_m`` of travel when new big orange cones (created within
        the last ``unseen_travel_m``) and old ones (not seen for longer) are both in the map and
        either as many new as old are seen or the old ones are behind the car.
        """
        if self.loop_closed:
            return True
        c = self.cfg
        if self.odometer_m < c.min_lap_distance_m or self.n_landmarks == 0:
            return False
        self._flush()
        big = self._big_mask()
        age_created = self.odometer_m - self._first_seen_m
        age_seen = self.odometer_m - self._last_seen_m
        new = np.flatnonzero(big & (age_created <= c.unseen_travel_m))
        old = np.flatnonzero(big & (age_seen > c.unseen_travel_m))
        if new.size < c.min_big_cone_pairs or old.size < c.min_big_cone_pairs:
            return False
        lm = self._xbuf[self._pd: self._n].reshape(-1, 2)
        if new.size < old.size:
            yaw = float(self._xbuf[2])
            ahead = ((lm[old] - self._xbuf[:2]) @ np.array([math.cos(yaw), math.sin(yaw)]))
            if np.any(ahead > 0.0):
                return False
        pairs = self._match_pattern(old, new)
        if pairs is None:
            return False
        old_idx, new_idx = pairs
        self._merge(old_idx, new_idx)
        self.loop_closed = True
        self.loop_closure_odometer_m = self.odometer_m
        merged = self._backward_sweep()
        self.merged_on_closure = int(old_idx.size) + merged
        log.info("loop closed at %.1f m: %d big cones, %d duplicates merged",
                 self.odometer_m, old_idx.size, merged)
        self.stats["loop_closures"] += 1
        return True

    def _match_pattern(self, old: NDArray[np.int64], new: NDArray[np.int64]
                       ) -> tuple[NDArray[np.int64], NDArray[np.int64]] | None:
        """Pair new with old big cones (landmark indices) under one common translation (drift).

        Each old-new pair within ``big_cone_search_m`` proposes a translation; it must be
        plausible under the filter's own uncertainty of that pair's difference (inflated by
        ``closure_covariance_inflation``, gated at ``merge_gate_probability``). The hypothesis
        with the most cones consistent within ``big_cone_pattern_tolerance_m`` wins, ties broken
        by the smaller Mahalanobis drift (the big cones' pattern repeats at a few metres, the
        drift is expected smaller). Returns landmark index arrays (old, new).
        """
        c = self.cfg
        lm = self._xbuf[self._pd: self._n].reshape(-1, 2)
        old_xy, new_xy = lm[old], lm[new]
        p = self.P
        best: tuple[int, float, NDArray[np.int64], NDArray[np.int64]] | None = None
        for i in range(old.size):
            for j in range(new.size):
                t = old_xy[i] - new_xy[j]
                if math.hypot(*t) > c.big_cone_search_m:
                    continue
                ci, cj = self._pd + 2 * int(old[i]), self._pd + 2 * int(new[j])
                cov = (p[ci:ci + 2, ci:ci + 2] + p[cj:cj + 2, cj:cj + 2]
                       - p[ci:ci + 2, cj:cj + 2] - p[cj:cj + 2, ci:ci + 2])
                cov = cov * c.closure_covariance_inflation + np.eye(2) * 1e-4
                d2 = float(t @ np.linalg.solve(cov, t))
                if d2 > self._merge_gate:
                    continue
                shifted = new_xy + t
                d = np.hypot(shifted[:, None, 0] - old_xy[None, :, 0],
                             shifted[:, None, 1] - old_xy[None, :, 1])
                cost = np.where(d <= c.big_cone_pattern_tolerance_m, d, _BIG)
                rows, cols = linear_sum_assignment(cost)
                good = cost[rows, cols] < _BIG
                count = int(np.count_nonzero(good))
                if best is None or count > best[0] or (count == best[0] and d2 < best[1]):
                    best = (count, d2, old[cols[good]], new[rows[good]])
        if best is None or best[0] < c.min_big_cone_pairs:
            return None
        return best[2], best[3]

    def _merge(self, keep: NDArray[np.int64], drop: NDArray[np.int64]) -> None:
        """Same-point measurement ``l_keep - l_drop = 0`` then delete ``drop`` (seed 5.3.2)."""
        a = keep.size
        cols = np.concatenate([(self._pd + 2 * keep[:, None] + np.arange(2)).ravel(),
                               (self._pd + 2 * drop[:, None] + np.arange(2)).ravel()])
        h = np.hstack([np.eye(2 * a), -np.eye(2 * a)])
        lm = self._xbuf[self._pd: self._n].reshape(-1, 2)
        y = -(lm[keep] - lm[drop]).ravel()
        r = np.eye(2 * a) * self.cfg.same_point_sigma_m ** 2
        self._update(cols, h, y, r)
        self._colour_votes[keep] += self._colour_votes[drop]
        self._size_votes[keep] += self._size_votes[drop]
        self._last_seen_m[keep] = np.maximum(self._last_seen_m[keep], self._last_seen_m[drop])
        self._delete_landmarks(drop)
        self._symmetrise()

    def _backward_sweep(self) -> int:
        """Merge duplicates newest first: a landmark and an older one never seen together."""
        c = self.cfg
        merged = 0
        order = np.argsort(-self._first_seen_m, kind="stable")
        ids_order = self._ids[order]
        for lid in ids_order:
            where = np.flatnonzero(self._ids == lid)
            if where.size == 0:
                continue
            j = int(where[0])
            cand = np.flatnonzero(self._last_seen_m < self._first_seen_m[j])
            if cand.size == 0:
                continue
            lm = self._xbuf[self._pd: self._n].reshape(-1, 2)
            d = np.hypot(lm[cand, 0] - lm[j, 0], lm[cand, 1] - lm[j, 1])
            close = d <= c.merge_distance_m
            if not np.any(close):
                continue
            cand, d = cand[close], d[close]
            k = int(cand[np.argmin(d)])
            p = self.P
            cj, ck = self._pd + 2 * j, self._pd + 2 * k
            s = (p[cj:cj + 2, cj:cj + 2] + p[ck:ck + 2, ck:ck + 2]
                 - p[cj:cj + 2, ck:ck + 2] - p[ck:ck + 2, cj:cj + 2])
            s += np.eye(2) * c.same_point_sigma_m ** 2
            diff = lm[j] - lm[k]
            if float(diff @ np.linalg.solve(s, diff)) > self._merge_gate:
                continue
            self._merge(np.array([k]), np.array([j]))
            merged += 1
        return merged

    # ----------------------------------------------------------------------------------------
    # Outputs
    # ----------------------------------------------------------------------------------------

    def pose(self) -> PoseEstimate:
        """The current pose; velocities rotated into the vehicle frame."""
        x, y, yaw, vx, vy = (float(v) for v in self._xbuf[:POSE_DIM])
        c, s = math.cos(yaw), math.sin(yaw)
        return PoseEstimate(
            timestamp_s=self.t_s if self.t_s is not None else 0.0,
            x_m=x, y_m=y, yaw_rad=yaw,
            vx_mps=c * vx + s * vy, vy_mps=-s * vx + c * vy,
            yaw_rate_radps=self._corrected_input()[0],
            covariance=self._pbuf[:3, :3].copy(),
        )

    def cone_map(self) -> ConeMap:
        """The landmarks as a :class:`ConeMap` (colour and size by majority vote)."""
        m = self.n_landmarks
        if m == 0:
            return ConeMap.empty()
        self._flush()
        c0 = self._pd + 2 * np.arange(m)
        cov = np.empty((m, 2, 2))
        p = self._pbuf
        cov[:, 0, 0] = p[c0, c0]
        cov[:, 0, 1] = cov[:, 1, 0] = p[c0 + 1, c0]          # the lower triangle: see _update
        cov[:, 1, 1] = p[c0 + 1, c0 + 1]
        return ConeMap(
            xy_m=self.landmarks_xy_m, covariance=cov, colour=self._colours(),
            size=self._sizes(), confidence=np.ones(m), ids=self._ids.copy(),
        )
