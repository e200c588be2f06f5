"""EKF SLAM with cones as landmarks (seed 000, section 5.3), as the Mapper drives it.

:class:`EkfSlam` takes the readings and keeps the rooms of :mod:`mapper.slam` together:

- Prediction with the IMU as input (:mod:`~mapper.slam.models`): the input over an interval is
  the mean of its two samples less the estimated biases, moved from the IMU mount
  (``car.imu_x_m``) to the rear axle. With ``SlamConfig.imu_bias_states`` (default) the gyro z
  and accelerometer x, y biases are states: the car may drive off without a standstill to
  calibrate them, and an uncorrected 0.002 rad/s gyro bias turns the map by 0.08 rad a lap.
  When it does stand at the start, the gyro's mean over the wait is one zero-rate update of
  the gyro bias state as it drives off (``standstill_gyro_calibration``).
- Wheel odometry: the rear axle's forward speed (the rear wheels read ``vx (1 +
  wheel_slip_per_mps2 a_x)``: the tyres' longitudinal slip) and its lateral velocity, which is
  only the tyres' slip in a corner, read from the accelerometer's lateral acceleration at the
  axle within the friction circle (:func:`mapper.motion.rear_slip_from_accel`; zero slip is the
  plain non-holonomic constraint). The yaw rate is an input (gyro), not a state, so the
  steering angle is not needed. GPS: the world-frame position, Mahalanobis-gated.
- One LiDAR sweep: cones stamped before the sweep's time are moved to it with the estimated
  motion (adding ``motion_compensation_sigma_mps * dt`` of noise), so the sweep is ONE batched
  update (seed 5.3 discusses the equivalence); then data association
  (:mod:`~mapper.slam.association`), the update, the preliminary list
  (:mod:`~mapper.slam.preliminary`) and a try at the loop closure
  (:mod:`~mapper.slam.loop_closure`).
- Camera cones vote for the colour of the nearest landmark (:mod:`~mapper.slam.landmarks`).
"""

from __future__ import annotations

import logging
import math
from collections import Counter
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from common.car import CarConfig
from common.messages import (
    ConeDetection,
    ConeMap,
    ImuSample,
    PoseEstimate,
    SteeringAngle,
    WheelSpeeds,
)
from mapper.chi2 import chi2_ppf
from mapper.config import MapperConfig
from mapper.imu_calibration import StaticCalibration
from mapper.motion import rear_slip_from_accel, rear_slip_velocity
from mapper.slam.association import Associator
from mapper.slam.ekf import SlamEkf
from mapper.slam.landmarks import N_COLOURS, N_SIZES, LandmarkBook
from mapper.slam.loop_closure import LoopClosure
from mapper.slam.models import POSE_DIM, FloatArray, lidar_noise, motion_model
from mapper.slam.preliminary import PreliminaryList

log = logging.getLogger(__name__)


class EkfSlam:
    """EKF SLAM (see the module docstring).

    ``x`` is the state (V + 2 N,), ``P`` its covariance (:class:`~mapper.slam.ekf.SlamEkf`);
    ``loop_closed`` says whether the controlled loop closure has happened. ``stats`` counts
    events and rejections by name; ``odometer_m`` is the travel so far (m).
    """

    def __init__(self, config: MapperConfig, car: CarConfig) -> None:
        self.cfg = config.slam
        self.car = car
        c = self.cfg
        self.stats: Counter[str] = Counter()
        self.ekf = SlamEkf(c, self.stats)
        self.book = LandmarkBook()
        self.associator = Associator(c)
        self.preliminary = PreliminaryList(c.preliminary_gate_m)
        self.closure = LoopClosure(c, self.stats)
        self._gps_gate = chi2_ppf(c.gps_gate_probability, 2)
        self._heading_seed = c.heading_mode == "seed"
        self.t_s: float | None = None
        self.odometer_m = 0.0
        self._last_imu: ImuSample | None = None
        ukf = config.ukf
        self._standstill: StaticCalibration | None = (
            StaticCalibration(ukf.static_gyro_threshold_radps, ukf.static_accel_threshold_mps2)
            if c.standstill_gyro_calibration and c.imu_bias_states else None)
        self._standstill_min_samples = ukf.static_min_samples
        self._input = (0.0, 0.0, 0.0, 0.0)
        """Last IMU input: yaw rate, specific force x, y, yaw acceleration (held between
        samples); see :meth:`_corrected_input`."""

    # ----------------------------------------------------------------------------------------
    # State access
    # ----------------------------------------------------------------------------------------

    @property
    def x(self) -> FloatArray:
        """The state vector (V + 2 N,), a view (landmark means brought up to date)."""
        return self.ekf.x

    @property
    def P(self) -> FloatArray:  # noqa: N802 (the conventional name)
        """The covariance (V + 2 N, V + 2 N), exactly symmetric, a view valid until the next
        update."""
        return self.ekf.P

    @property
    def n_landmarks(self) -> int:
        """Number of landmarks in the filter."""
        return self.ekf.n_landmarks

    @property
    def landmarks_xy_m(self) -> FloatArray:
        """Landmark positions (N, 2), world frame (a copy)."""
        self.ekf.flush_mean()
        return self.ekf.landmarks_view().copy()

    @property
    def preliminary_xy_m(self) -> FloatArray:
        """The preliminary landmark list (K, 2), world frame."""
        return self.preliminary.xy.copy()

    @property
    def vehicle_dim(self) -> int:
        """Number of vehicle states before the landmarks: 5 (pose) or 8 (pose and IMU biases)."""
        return self.ekf.vdim

    @property
    def imu_bias(self) -> tuple[float, float, float]:
        """Estimated gyro z (rad/s), accelerometer x and y (m/s^2) biases (zero if not states)."""
        if self.ekf.vdim == POSE_DIM:
            return 0.0, 0.0, 0.0
        xbuf = self.ekf.xbuf
        return float(xbuf[5]), float(xbuf[6]), float(xbuf[7])

    @property
    def loop_closed(self) -> bool:
        """Whether the controlled loop closure has happened."""
        return self.closure.closed

    @property
    def loop_closure_odometer_m(self) -> float:
        """Travel (m) when the loop closed (NaN before)."""
        return self.closure.odometer_m

    @property
    def merged_on_closure(self) -> int:
        """Landmarks merged when the loop closed (big cone pairs and duplicates)."""
        return self.closure.merged

    def load_state(self, x: FloatArray, p: FloatArray, timestamp_s: float = 0.0) -> None:
        """Replace the state (V + 2 N,) and covariance; landmarks get fresh ids, seen now.

        ``V`` is 5 (the pose, an odd-sized state: the IMU biases are then not estimated) or 8
        (pose and biases, even-sized). For tests and benchmarks (and restoring a saved filter).
        """
        self.ekf.load(np.asarray(x, np.float64).reshape(-1), np.asarray(p, np.float64))
        self.book.reset(self.ekf.n_landmarks, self.odometer_m)
        self.t_s = timestamp_s

    def update_landmarks(self, z: FloatArray, r: FloatArray, landmarks: NDArray[np.int64]
                         ) -> bool:
        """The batched update for KNOWN associations: detections ``z`` (a, 2) in the vehicle
        frame at the filter's time, noise ``r`` (a, 2, 2), landmark indices (a,)."""
        self.ekf.flush()
        return self.ekf.update_landmarks(np.asarray(z, np.float64).reshape(-1, 2),
                                         np.asarray(r, np.float64).reshape(-1, 2, 2),
                                         np.asarray(landmarks, np.int64).reshape(-1))

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
        if self._standstill is not None and not self._standstill.still(imu):
            self._end_standstill()
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

    def _end_standstill(self) -> None:
        """The car moves: the gyro's mean while it stood is its bias, known to the samples'
        standard error (a zero-rate update on the gyro bias state, once).

        The landmarks alone pin the bias only as well as they pin the yaw over the wait (0.12
        mrad/s after 8 s on the simulated car), and a bias wrong by 0.1 mrad/s turns the
        explored lap by 0.2 deg in 30 s; the gyro's own mean knows it to its white noise
        (0.05 mrad/s after 8 s at 200 Hz)."""
        still = self._standstill
        assert still is not None
        self._standstill = None
        if still.count < self._standstill_min_samples:
            self.stats["standstill_calibration_skipped"] += 1
            log.info("SLAM gyro calibration skipped: the car moved after %d standing samples",
                     still.count)
            return
        self.ekf.flush()
        mean_radps = float(still.mean()[0])
        var = float(still.variance_of_mean()[0])
        ok = self.ekf.update_vehicle(np.array([5]), np.ones((1, 1)),
                                     np.array([mean_radps - float(self.ekf.xbuf[5])]),
                                     np.array([[var]]))
        self.stats["standstill_calibration"] += int(ok)
        log.info("SLAM gyro bias from %d standing samples: %.3f +- %.3f mrad/s", still.count,
                 1e3 * mean_radps, 1e3 * math.sqrt(var))

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
        if self.ekf.vdim > POSE_DIM:
            xbuf = self.ekf.xbuf
            w -= float(xbuf[5])
            ax -= float(xbuf[6])
            ay -= float(xbuf[7])
        if self.cfg.imu_lever_arm and self.car.imu_x_m != 0.0:
            r = self.car.imu_x_m
            ax += w * w * r
            ay -= w_dot * r
        return w, ax, ay

    def _propagate(self, dt: float) -> None:
        w, ax, ay = self._corrected_input()
        k = 0.5 * dt * dt if self._heading_seed else 0.5 * dt
        pose = self.ekf.xbuf[:POSE_DIM]
        speed_mps = math.hypot(float(pose[3]), float(pose[4]))
        new, f5, g = motion_model(pose, w, ax, ay, dt, k)
        self.odometer_m += dt * speed_mps
        self.ekf.predict(new, f5, g, dt)

    # ----------------------------------------------------------------------------------------
    # Odometry and GPS
    # ----------------------------------------------------------------------------------------

    def update_odometry(self, ws: WheelSpeeds, steer: SteeringAngle | None = None) -> None:
        """Wheel odometry: the rear axle's forward speed and its lateral velocity.

        The lateral velocity of the rear axle is not zero in a corner: the rear tyres run at a
        slip angle ``alpha = rear_slip_rad_per_mps2 * a_y`` (their cornering stiffness), so the
        axle slides outwards at ``vy = -vx * alpha``, ``a_y = vx * w``. The pseudo-measurement is
        ``vy = vy_slip(vx, w)``, its noise growing with the slip (``lateral_slip_sigma_fraction``).
        ``steer`` is accepted for the interface but not needed (the yaw rate is the gyro's). The
        driven or braked rear tyres slip: the wheels read ``vx (1 + k a_x)`` with ``a_x`` the
        axle's longitudinal acceleration (the IMU input less its bias; ``k`` =
        ``wheel_slip_per_mps2``).
        """
        del steer
        if not self.cfg.use_odometry:
            return
        v = ws.mean_rear_mps
        if not math.isfinite(v) or not math.isfinite(ws.timestamp_s):
            self.stats["odometry_rejected_nonfinite"] += 1
            return
        self.predict_to(ws.timestamp_s)
        _, _, yaw, vx, vy = self.ekf.xbuf[:POSE_DIM]
        c, s = math.cos(yaw), math.sin(yaw)
        vxb, vyb = c * vx + s * vy, -s * vx + c * vy
        w, ax, ay = self._corrected_input()
        biased = self.ekf.vdim > POSE_DIM
        lever = self.cfg.imu_lever_arm
        from_accel = self.cfg.slip_from_accelerometer
        if from_accel:
            vy_slip, d_vx, d_ay, d_ax = rear_slip_from_accel(
                vxb, ay, ax, self.cfg.rear_slip_rad_per_mps2, self.car.max_lateral_accel_mps2)
            d_w = 0.0
        else:
            a_max = (self.car.max_lateral_accel_mps2 if self.cfg.rear_slip_saturation
                     else math.inf)
            vy_slip, d_vx, d_w = rear_slip_velocity(vxb, w, self.cfg.rear_slip_rad_per_mps2,
                                                    a_max)
            d_ay = d_ax = 0.0
        # Longitudinal slip: the driven / braked rear tyres turn faster / slower than the axle
        # moves, by a fraction proportional to the longitudinal force (a_x of the axle).
        k = self.cfg.wheel_slip_per_mps2
        scale = 1.0 + k * ax
        # d vxb / d (yaw, vx, vy) and d vyb / d (yaw, vx, vy)
        dvxb = np.array([vyb, c, s])
        dvyb = np.array([-vxb, -s, c])
        h = np.zeros((2, 6 if biased else 3))
        h[0, :3] = scale * dvxb
        h[1, :3] = dvyb - d_vx * dvxb
        if biased:
            # The inputs less their biases: w = gyro - b_gz, a_x = accel - b_ax (+ w^2 r from
            # the lever arm), a_y = accel - b_ay; the measurement is (wheels, vyb - vy_slip).
            d_ax_d_bgz = -2.0 * w * self.car.imu_x_m if lever else 0.0
            h[0, 3] = k * vxb * d_ax_d_bgz
            h[0, 4] = -k * vxb
            h[1, 3] = d_w - d_ax * d_ax_d_bgz
            h[1, 4] = d_ax
            h[1, 5] = d_ay
        pred = np.array([scale * vxb, vyb - vy_slip])
        lat_sigma = (self.cfg.lateral_velocity_sigma_mps
                     + self.cfg.lateral_slip_sigma_fraction * abs(vy_slip))
        r = np.diag([self.cfg.wheel_speed_sigma_mps ** 2
                     + (self.cfg.wheel_speed_sigma_fraction * vxb) ** 2, lat_sigma ** 2])
        cols = np.array([2, 3, 4, 5, 6, 7]) if biased else np.array([2, 3, 4])
        self.ekf.update_vehicle(cols, h, np.array([v, 0.0]) - pred, r)
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
        y = z - self.ekf.xbuf[:2]
        s = self.ekf.pbuf[:2, :2] + r
        d2 = float(y @ np.linalg.solve(s, y))
        if d2 > self._gps_gate:
            self.stats["gps_rejected_gate"] += 1
            return False
        ok = self.ekf.update_vehicle(np.array([0, 1]), np.eye(2), y, r)
        self.stats["gps_updates"] += int(ok)
        return ok

    # ----------------------------------------------------------------------------------------
    # Cones
    # ----------------------------------------------------------------------------------------

    def _active_mask(self) -> NDArray[np.bool_]:
        """Landmarks that may be associated (seed 5.3.2: recently seen, or all after closure)."""
        if self.loop_closed and self.cfg.associate_all_after_closure:
            return np.ones(self.n_landmarks, bool)
        return (self.odometer_m - self.book.last_seen_m) <= self.cfg.unseen_travel_m

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
        self.ekf.flush()
        self.stats["sweeps"] += 1
        if not cones:
            self.preliminary.clear()
            return 0
        raw = np.array([(d.x_m, d.y_m, d.timestamp_s) for d in cones], np.float64)
        sizes = np.array([int(d.size) for d in cones], np.int64)
        colours = np.array([int(d.colour) for d in cones], np.int64)
        z = raw[:, :2]
        ok = np.all(np.isfinite(raw), axis=1) & (np.hypot(z[:, 0], z[:, 1]) <= c.max_range_m)
        ok &= (sizes >= 0) & (sizes < N_SIZES) & (colours >= 0) & (colours < N_COLOURS)
        if not np.all(ok):
            self.stats["cones_rejected"] += int(np.count_nonzero(~ok))
            raw, z, sizes, colours = raw[ok], z[ok], sizes[ok], colours[ok]
            if raw.shape[0] == 0:
                return 0
        # Move each detection to the sweep timestamp with the estimated motion.
        dt = timestamp_s - raw[:, 2]
        extra = (c.motion_compensation_sigma_mps * dt) ** 2
        if np.any(dt != 0.0):
            xbuf = self.ekf.xbuf
            yaw, vxw, vyw = xbuf[2], xbuf[3], xbuf[4]
            cy, sy = math.cos(yaw), math.sin(yaw)
            vb = np.array([cy * vxw + sy * vyw, -sy * vxw + cy * vyw])
            # z_T = R(-w dt) z_i - R(-w dt / 2) v_body dt (the car moved along an arc).
            ang = self._corrected_input()[0] * dt
            ca, sa = np.cos(ang), np.sin(ang)
            ch, sh = np.cos(0.5 * ang), np.sin(0.5 * ang)
            z = np.stack([ca * z[:, 0] + sa * z[:, 1] - dt * (ch * vb[0] + sh * vb[1]),
                          -sa * z[:, 0] + ca * z[:, 1] - dt * (-sh * vb[0] + ch * vb[1])],
                         axis=1)
        r_all = lidar_noise(z, extra, self.car.lidar_x_m, c)

        n_det = z.shape[0]
        found = self.associator.associate(self.ekf, z, r_all, self._active_mask(), sizes,
                                          self.book.sizes())
        assigned_det, assigned_lm = found.detections, found.landmarks
        if assigned_det.size:
            self.ekf.update_landmarks(z[assigned_det], r_all[assigned_det], assigned_lm)
            self.book.seen(assigned_lm, self.odometer_m, sizes[assigned_det],
                           colours[assigned_det])
        self.stats["cones_associated"] += int(assigned_det.size)
        free = np.ones(n_det, bool)
        free[assigned_det] = False
        free &= ~found.near_any
        self.stats["cones_ambiguous"] += int(n_det - assigned_det.size - np.count_nonzero(free))
        self._preliminary(z[free], r_all[free], sizes[free], colours[free])
        if not self.loop_closed:
            self.try_close_loop()
        return int(assigned_det.size)

    def _preliminary(self, z: FloatArray, r: FloatArray, sizes: NDArray[np.int64],
                     colours: NDArray[np.int64]) -> None:
        """Seed 5.3.3: detections seen again since the previous sweep become landmarks; the
        rest wait in the preliminary list."""
        xbuf = self.ekf.xbuf
        yaw = float(xbuf[2])
        cy, sy = math.cos(yaw), math.sin(yaw)
        rot = np.array([[cy, -sy], [sy, cy]])
        world = xbuf[:2] + z @ rot.T
        promote = self.preliminary.promote(world, sizes, colours)
        if np.any(promote):
            self._add_landmarks(z[promote], r[promote], sizes[promote], colours[promote])

    def _add_landmarks(self, z: FloatArray, r: FloatArray, sizes: NDArray[np.int64],
                       colours: NDArray[np.int64]) -> None:
        """State augmentation: ``l = p + R(yaw) z`` with its covariance and cross terms."""
        self.ekf.augment(z, r)
        self.book.add(self.odometer_m, sizes, colours)
        self.stats["landmarks_added"] += z.shape[0]

    def delete_landmarks(self, lm: NDArray[np.int64]) -> None:
        """Remove landmarks ``lm`` (their rows and columns) from the filter."""
        self.book.keep(self.ekf.delete(lm))
        self.stats["landmarks_deleted"] += int(lm.size)

    def merge_landmarks(self, keep: NDArray[np.int64], drop: NDArray[np.int64]) -> None:
        """Merge landmarks ``drop`` into ``keep`` (a same-point measurement; seed 5.3.2)."""
        self.closure.merge(self.ekf, self.book, keep, drop)

    def try_close_loop(self) -> bool:
        """Controlled loop closure (seed 5.3.2, :mod:`mapper.slam.loop_closure`); True once
        the loop is closed."""
        return self.closure.try_close(self.ekf, self.book, self.odometer_m)

    def add_colour_votes(self, cones: Sequence[ConeDetection], pose: PoseEstimate | None = None
                         ) -> int:
        """Camera cones (vehicle frame at ``pose``; default the current estimate) vote for the
        colour of the nearest landmark within ``colour_gate_m`` (world frame), weighted by their
        confidence. Returns the number of votes cast."""
        if not cones or self.n_landmarks == 0:
            return 0
        self.ekf.flush_mean()
        at = ((pose.x_m, pose.y_m, pose.yaw_rad) if pose is not None
              else tuple(float(v) for v in self.ekf.xbuf[:3]))
        return self.book.vote_colours(cones, at, self.ekf.landmarks_view(),  # type: ignore[arg-type]
                                      self.cfg.colour_gate_m)

    # ----------------------------------------------------------------------------------------
    # Outputs
    # ----------------------------------------------------------------------------------------

    def pose(self) -> PoseEstimate:
        """The current pose; velocities rotated into the vehicle frame."""
        x, y, yaw, vx, vy = (float(v) for v in self.ekf.xbuf[:POSE_DIM])
        c, s = math.cos(yaw), math.sin(yaw)
        return PoseEstimate(
            timestamp_s=self.t_s if self.t_s is not None else 0.0,
            x_m=x, y_m=y, yaw_rad=yaw,
            vx_mps=c * vx + s * vy, vy_mps=-s * vx + c * vy,
            yaw_rate_radps=self._corrected_input()[0],
            covariance=self.ekf.pbuf[:3, :3].copy(),
        )

    def cone_map(self) -> ConeMap:
        """The landmarks as a :class:`ConeMap` (colour and size by majority vote)."""
        m = self.n_landmarks
        if m == 0:
            return ConeMap.empty()
        self.ekf.flush()
        c0 = self.ekf.vdim + 2 * np.arange(m)
        cov = np.empty((m, 2, 2))
        p = self.ekf.pbuf
        cov[:, 0, 0] = p[c0, c0]
        cov[:, 0, 1] = cov[:, 1, 0] = p[c0 + 1, c0]          # the lower triangle: see the EKF
        cov[:, 1, 1] = p[c0 + 1, c0 + 1]
        return ConeMap(
            xy_m=self.landmarks_xy_m, covariance=cov, colour=self.book.colours(),
            size=self.book.sizes(), confidence=np.ones(m), ids=self.book.ids.copy(),
        )

