"""The Mapper (Tier 2): readings in, :class:`MapState` out.

Backends (``mapper.backend``):

- ``slam``: EKF SLAM of seed 000 (:class:`mapper.ekf_slam.EkfSlam`) maps and localises;
- ``smoother``: seed 002's pipeline: the UKF of seed 001 gives the pose, LiDAR objects are put
  in the world (object localisation), filtered and merged by the time smoother.

Either way, once the loop is closed (SLAM's controlled loop closure, or for the smoother: back
within ``fusion.loop_close_radius_m`` of the start after ``fusion.loop_min_distance_m`` of
travel) the map is frozen (``MapState.map_frozen``) and the car localises on it with the UKF and
its cone update. Camera cones bring colour (a vote per associated detection); LiDAR brings
position. With the ``slam`` backend the UKF does not run before the freeze: it is seeded then
from the SLAM's pose, velocities and IMU bias estimates (:meth:`Mapper._hand_over_to_ukf`).
With the ``smoother`` backend the UKF (with IMU bias states) also localises on the objects the
smoother has confirmed (``fusion.smoother_localise``) during the exploration.

Timing (seed 000, 6.2.1): readings are applied in the order they were made through a
:class:`mapper.fusion.DelayBuffer`; the output pose is the lagged estimate predicted forward to
the newest IMU sample. An :meth:`update` call with a few readings costs one short
prediction and no map work; the heavy work happens once per LiDAR sweep.
"""

from __future__ import annotations

import logging
import math
from collections import Counter, deque
from collections.abc import Sequence
from typing import Any

import numpy as np

from common.car import CarConfig
from common.conventions import LocalTangentFrame, WorldFrame, vehicle_to_world, wrap_angle
from common.messages import (
    CameraCones,
    ConeColour,
    ConeMap,
    GpsFix,
    ImuSample,
    LidarCones,
    MapState,
    PoseEstimate,
    Reading,
    SteeringAngle,
    WheelSpeeds,
)
from mapper.config import MapperConfig
from mapper.delay_buffer import DelayBuffer
from mapper.gnss_frame import GnssFrameEstimator
from mapper.motion import compensate_motion, predict_forward
from mapper.object_filter import ObjectFilter, detection_sizes, localise_objects
from mapper.time_smoother import N_COLOURS, TimeSmoother
from mapper.ukf_localiser import N_BIAS, N_STATE, UkfLocaliser

log = logging.getLogger(__name__)

_STREAMS: dict[type, str] = {
    ImuSample: "imu",
    WheelSpeeds: "wheels",
    SteeringAngle: "steering",
    GpsFix: "gps",
    LidarCones: "lidar",
    CameraCones: "camera",
}


class Mapper:
    """Maps and localises from parsed readings; see the module docstring.

    ``world_frame`` is the GNSS world frame once known (else None); ``stats`` counts applied,
    rejected and skipped measurements per sensor.
    """

    def __init__(self, config: MapperConfig, car: CarConfig,
                 start_heading_enu_rad: float | None = None) -> None:
        """``start_heading_enu_rad``: the world frame's heading in ENU (rad) when it is known
        (the mission's; None: estimated from the GNSS course)."""
        self.config = config
        self.car = car
        self.start_heading_enu_rad = start_heading_enu_rad
        mc = config
        self.backend = mc.backend
        self.ukf = UkfLocaliser(mc.ukf, car)
        self.slam: Any = None
        if self.backend == "slam":
            from mapper.slam.ekf_slam import EkfSlam

            self.slam = EkfSlam(mc, car)
        self.smoother = TimeSmoother(mc.smoother)
        self.object_filter = ObjectFilter(mc.object_filter)
        self.buffer = DelayBuffer(mc.fusion.max_delay_s)
        self.world_frame: WorldFrame | None = None
        self._enu: LocalTangentFrame | None = None
        self._frame_estimator: GnssFrameEstimator | None = None
        self._steer: SteeringAngle | None = None
        self._last_wheels_s: float | None = None
        self._recent_imu: deque[ImuSample] = deque()
        self.odometer_m = 0.0
        self.map_frozen = False
        self.loop_closed = False
        self._frozen_map: ConeMap | None = None
        self._frozen_votes = np.zeros((0, N_COLOURS))
        self._cones_cache: ConeMap = ConeMap.empty()
        self._cones_dirty = False
        self._counts: dict[str, Counter[str]] = {}
        self._state = MapState(0.0, PoseEstimate(0.0, 0.0, 0.0, 0.0), ConeMap.empty(),
                               backend=self.backend)

    # -- public -------------------------------------------------------------------------------

    def update(self, readings: Sequence[Reading], now_s: float) -> MapState:
        """Take parsed readings (time order; other types ignored) and return the state at now."""
        for r in readings:
            stream = _STREAMS.get(type(r))
            if stream is None:
                continue
            if not math.isfinite(r.timestamp_s):
                self._count(stream, "rejected_bad_time")
                continue
            if self.buffer.push(stream, r, now_s) and isinstance(r, ImuSample):
                self._recent_imu.append(r)
        for stream, r in self.buffer.pop_ready(now_s):
            try:
                self._apply(stream, r)
            except (ValueError, np.linalg.LinAlgError, FloatingPointError) as exc:
                self._count(stream, "error")
                log.warning("mapper: %s reading at %.3f s failed: %s", stream, r.timestamp_s, exc)
        self._state = self._make_state(now_s)
        return self._state

    def state(self) -> MapState:
        """The last :class:`MapState` returned by :meth:`update`."""
        return self._state

    def freeze(self, known_map: ConeMap | None = None) -> None:
        """Freeze the map: the current one, or ``known_map`` (a surveyed map); from now on the
        UKF localises against it."""
        cone_map = known_map if known_map is not None else self._live_map()
        own_slam_map = self.slam is not None and known_map is None
        if self.slam is not None and not self.map_frozen:
            self._hand_over_to_ukf(own_map=own_slam_map)
            if own_slam_map and self.ukf.consider_map is not None:
                cone_map = self.ukf.consider_map
        if not own_slam_map and cone_map is not self._frozen_map:
            # A surveyed map or the smoother's: independent cones, each with its covariance.
            self.ukf.set_map(cone_map)
        self._frozen_map = cone_map
        votes = np.zeros((len(cone_map), N_COLOURS))
        known = cone_map.colour > int(ConeColour.UNKNOWN)
        votes[np.flatnonzero(known), cone_map.colour[known]] = 3.0
        self._frozen_votes = votes
        self.map_frozen = True
        self._cones_dirty = True
        log.info("map frozen with %d cones", len(cone_map))

    @property
    def stats(self) -> dict[str, dict[str, int]]:
        """Counts per sensor and outcome: applied / rejected / skipped_... / late."""
        out: dict[str, dict[str, int]] = {}
        for source in (self.ukf.stats, self._counts):
            for sensor, counter in source.items():
                row = out.setdefault(sensor, {})
                for outcome, n in counter.items():
                    row[outcome] = row.get(outcome, 0) + n
        for stream, n in self.buffer.late.items():
            out.setdefault(stream, {})["late"] = n
        if self.object_filter.rejects:
            out["object_filter"] = dict(self.object_filter.rejects)
        if self.slam is not None:
            out["slam"] = dict(self.slam.stats)
        return out

    def _hand_over_to_ukf(self, own_map: bool = True) -> None:
        """Seed the UKF from the SLAM (pose, velocities, IMU biases, their covariances): with
        the ``slam`` backend the UKF does not run before the map freezes.

        With ``own_map`` (the SLAM's map is frozen) the UKF takes the SLAM's joint covariance:
        its vehicle block mapped to the UKF's states, the landmark block as the map's error
        covariance and the vehicle-landmark block as their cross-covariance (the map's errors
        are consider states of the UKF: :meth:`UkfLocaliser.set_map`); else the map is set by
        the caller."""
        slam = self.slam
        ukf = self.ukf
        ukf.set_map(None)
        ukf.reset(slam.pose())
        ukf.x[3:6] = self._slam_velocity()
        ukf.t_s = slam.t_s
        v = slam.vehicle_dim
        if v > 5:
            # The SLAM estimated the IMU biases on the way (the car may never have stood
            # still for the UKF's static calibration): the UKF goes on with them.
            ukf.set_imu_bias(slam.imu_bias, np.array(slam.P[5:v, 5:v]))
        else:
            ukf.calibrating = False
        if not own_map:
            return
        P = np.array(slam.P)
        T = slam_to_ukf_jacobian(ukf.x, v, ukf.n)
        pv = T @ P[:v, :v] @ T.T
        # The UKF's yaw-rate state is the last gyro sample less the bias: the gyro's noise.
        pv[5, 5] += self.config.ukf.gyro_sigma_radps ** 2
        keep = [ukf.ih] if ukf.ih is not None else []
        if v == 5 or not ukf.nb:
            # Bias states in one filter only: they keep what set_imu_bias / reset gave them.
            keep += list(range(6, 6 + ukf.nb))
        if keep:
            kept = ukf.P[np.ix_(keep, keep)]
            pv[keep, :] = 0.0
            pv[:, keep] = 0.0
            pv[np.ix_(keep, keep)] = kept
        ukf.reset(ukf.pose(), covariance=0.5 * (pv + pv.T))
        ukf.t_s = slam.t_s
        ukf.set_map(slam.cone_map(), P[v:, v:], T @ P[:v, v:])
        self._refine_gnss_frame()

    def _refine_gnss_frame(self) -> None:
        """At the freeze: the frame heading from every course of the exploration lap against the
        SLAM's yaw (:meth:`GnssFrameEstimator.heading_estimate`); the UKF's offset state starts
        at zero with its sigma."""
        cfg = self.config.ukf
        estimator = self._frame_estimator
        if (not cfg.gnss_frame_refine or estimator is None or self.world_frame is None
                or estimator.method != "course"):
            return
        estimate = estimator.heading_estimate()
        if estimate is None:
            return
        heading, sigma = estimate
        old = self.world_frame
        self.world_frame = WorldFrame(old.enu, old.start_east_m, old.start_north_m,
                                      wrap_angle(heading))
        self.ukf.set_gnss_heading_offset(0.0, sigma)
        log.info("GNSS frame heading refined over the exploration lap: %.4f -> %.4f rad "
                 "(sigma %.4f)", old.start_yaw_enu_rad, heading, sigma)

    # -- per reading --------------------------------------------------------------------------

    def _count(self, sensor: str, outcome: str) -> None:
        self._counts.setdefault(sensor, Counter())[outcome] += 1

    def _slam_active(self) -> bool:
        return self.slam is not None and not self.map_frozen

    def _apply(self, stream: str, r: Reading) -> None:
        slam_active = self.slam is not None and not self.map_frozen
        if isinstance(r, ImuSample):
            if slam_active:
                self.slam.predict(r)
            else:
                self.ukf.predict(r)
        elif isinstance(r, WheelSpeeds):
            if self._last_wheels_s is not None:
                dt = r.timestamp_s - self._last_wheels_s
                if 0.0 < dt < 1.0:
                    self.odometer_m += abs(r.mean_rear_mps) * dt
            self._last_wheels_s = r.timestamp_s
            if slam_active:
                self.slam.update_odometry(r, self._steer)
                if self.config.slam.use_odometry:
                    self._count("odometry", "applied")
            else:
                self.ukf.update_odometry(r, self._steer)
        elif isinstance(r, SteeringAngle):
            self._steer = r
        elif isinstance(r, GpsFix):
            self._on_gps(r)
        elif isinstance(r, LidarCones):
            self._on_lidar(r)
        elif isinstance(r, CameraCones):
            self._on_camera(r)

    def _on_gps(self, fix: GpsFix) -> None:
        cfg = self.config.ukf
        if fix.fix_quality == 0 or not (math.isfinite(fix.lat_deg)
                                        and math.isfinite(fix.lon_deg)):
            self._count("gnss", "rejected_invalid")
            return
        if self._enu is None:
            alt = fix.altitude_m if math.isfinite(fix.altitude_m) else 0.0
            self._enu = LocalTangentFrame(fix.lat_deg, fix.lon_deg, alt)
            known = self.start_heading_enu_rad
            self._frame_estimator = GnssFrameEstimator(
                self._enu, known, cfg.heading_estimate_samples, cfg.gnss_min_speed_mps,
                cfg.track_alignment_distance_m,
                max_yaw_rate_radps=cfg.heading_estimate_max_yaw_rate_radps,
                yaw_error_correlation_s=cfg.heading_yaw_error_correlation_s,
                alignment_heading_sigma_rad=cfg.track_alignment_heading_sigma_rad)
        e, n, _ = self._enu.to_enu(fix.lat_deg, fix.lon_deg, self._enu.alt0_m)
        east, north = float(e), float(n)
        estimator = self._frame_estimator
        assert estimator is not None
        if self.world_frame is None or (self._slam_active() and cfg.gnss_frame_refine):
            # Until the frame is found, and on with the SLAM's yaw for the refinement at the
            # freeze (not with the UKF's: once it takes courses its yaw leans on them).
            p = self.slam.pose() if self._slam_active() else self.ukf.pose()
            state = np.array([p.x_m, p.y_m, p.yaw_rad, p.vx_mps, p.vy_mps])
            found = self.world_frame is None
            self.world_frame = estimator.add(east, north, fix.speed_mps, fix.course_rad, state,
                                             float(p.covariance[2, 2]), p.yaw_rate_radps,
                                             fix.timestamp_s)
            if found:
                if self.world_frame is None:
                    self._count("gnss", "frame_pending")
                    return
                self._count("gnss", "frame_found")
                # A known heading (sigma 0) keeps the configured, about-zero sigma.
                self.ukf.set_gnss_heading_offset(
                    0.0, max(estimator.frame_sigma_rad, cfg.initial_gnss_heading_sigma_rad))
                return
        assert self.world_frame is not None
        xy = self.world_frame.enu_to_world(east, north).reshape(2)
        if self._slam_active():
            self.slam.update_gps_xy(xy, np.eye(2) * self.config.slam.gps_sigma_m**2,
                                    fix.timestamp_s)
            return
        self.ukf.update_gnss_position(xy)
        course = (self.world_frame.enu_yaw_to_world_yaw(fix.course_rad)
                  if math.isfinite(fix.course_rad) else math.nan)
        self.ukf.update_gnss_velocity(fix.speed_mps, course)

    def _on_lidar(self, sweep: LidarCones) -> None:
        cones = self.object_filter.filter(sweep.cones)
        if self._slam_active():
            self.slam.update_cones(cones, sweep.timestamp_s)
            self._cones_dirty = True
            if self.slam.try_close_loop():
                self.loop_closed = True
                self.freeze()
            return
        if not cones:
            return
        x = self.ukf.x
        # To the UKF's own time (its last IMU sample, up to one IMU period before the sweep's
        # stamp): the detections are compared with the pose at that time.
        t_ref = self.ukf.t_s if self.ukf.t_s is not None else sweep.timestamp_s
        xy_vehicle = compensate_motion(cones, t_ref, float(x[3]), float(x[4]), float(x[5]))
        if self.map_frozen:
            assert self._frozen_map is not None
            self.ukf.update_cones_on_map(cones, self._frozen_map, xy_vehicle)
            return
        fc = self.config.fusion
        if fc.smoother_localise:
            # SLAM without cross-covariances: localise on the objects the smoother has
            # confirmed, then add this sweep to them.
            confirmed = self.smoother.confirmed_map(fc.smoother_localise_min_matches,
                                                    fc.smoother_localise_map_sigma_floor_m)
            if len(confirmed):
                self.ukf.update_cones_on_map(cones, confirmed, xy_vehicle,
                                             full_update=fc.smoother_localise_full_update,
                                             cone_sigma_m=fc.smoother_localise_sigma_m)
                x = self.ukf.x
        pose = (float(x[0]), float(x[1]), float(x[2]))
        xy_world = vehicle_to_world(xy_vehicle, *pose).reshape(-1, 2)
        lidar = vehicle_to_world([self.car.lidar_x_m, 0.0], *pose).reshape(2)
        colours = np.array([int(c.colour) for c in cones], np.int64)
        self.smoother.update(xy_world, detection_sizes(cones),
                             (float(lidar[0]), float(lidar[1]), pose[2]), colours)
        self._cones_dirty = True
        if (self.odometer_m >= fc.loop_min_distance_m
                and math.hypot(pose[0], pose[1]) <= fc.loop_close_radius_m):
            self.loop_closed = True
            log.info("smoother loop closed after %.1f m", self.odometer_m)
            self.freeze()

    def _on_camera(self, frame: CameraCones) -> None:
        fc = self.config.fusion
        cones = [c for c in frame.cones
                 if math.isfinite(c.x_m) and math.isfinite(c.y_m)
                 and int(ConeColour.UNKNOWN) < int(c.colour) < N_COLOURS]
        if not cones:
            return
        if self._slam_active():
            self.slam.add_colour_votes(cones, self.slam.pose())
            self._cones_dirty = True
            return
        x = self.ukf.x
        xy = localise_objects(cones, float(x[0]), float(x[1]), float(x[2]))
        colours = np.array([int(c.colour) for c in cones], np.int64)
        weights = np.array([min(max(c.confidence, 0.0), 1.0) for c in cones])
        if self.map_frozen:
            assert self._frozen_map is not None
            if len(self._frozen_map) == 0:
                return
            from scipy.spatial import cKDTree

            dist, idx = cKDTree(self._frozen_map.xy_m).query(xy, k=1,
                                                             distance_upper_bound=fc.colour_gate_m)
            ok = np.isfinite(dist)
            np.add.at(self._frozen_votes, (np.asarray(idx)[ok], colours[ok]), weights[ok])
        else:
            self.smoother.add_colour_votes(xy, colours, fc.colour_gate_m, weights)
        self._cones_dirty = True

    # -- output -------------------------------------------------------------------------------

    def _slam_velocity(self) -> np.ndarray:
        p = self.slam.pose()
        return np.array([p.vx_mps, p.vy_mps, p.yaw_rate_radps])

    def _live_map(self) -> ConeMap:
        if self._slam_active():
            cone_map: ConeMap = self.slam.cone_map()
            return cone_map
        return self.smoother.cone_map()

    def _cones(self) -> ConeMap:
        if not self._cones_dirty:
            return self._cones_cache
        self._cones_dirty = False
        if self.map_frozen and self._frozen_map is not None:
            fm = self._frozen_map
            votes = self._frozen_votes
            colour = np.where(votes.max(axis=1) > 0.0, np.argmax(votes, axis=1),
                              int(ConeColour.UNKNOWN)) if len(fm) else fm.colour
            self._cones_cache = ConeMap(fm.xy_m, fm.covariance, colour, fm.size, fm.confidence,
                                        fm.ids)
        else:
            self._cones_cache = self._live_map()
        return self._cones_cache

    def _make_state(self, now_s: float) -> MapState:
        if self._slam_active():
            lagged = self.slam.pose()
            state = np.array([lagged.x_m, lagged.y_m, lagged.yaw_rad, lagged.vx_mps,
                              lagged.vy_mps, lagged.yaw_rate_radps])
            cov = lagged.covariance
            t_lag = lagged.timestamp_s
        else:
            state = self.ukf.x
            cov = self.ukf.P[:3, :3]
            t_lag = self.ukf.t_s if self.ukf.t_s is not None else now_s
        recent = self._recent_imu
        while recent and recent[0].timestamp_s <= t_lag:
            recent.popleft()
        if self._slam_active():
            bg, bax, bay = self.slam.imu_bias
            calibrating = False
        else:
            bg, bax, bay = self.ukf.imu_bias
            calibrating = self.ukf.calibrating
        gyro_bias, accel_bias = bg, np.array([bax, bay])
        if recent and not calibrating:
            pred, t = predict_forward(state, t_lag, recent, gyro_bias, accel_bias,
                                      self.car.imu_x_m)
        else:  # standing still (calibrating) or nothing newer: the lagged state holds
            pred = np.asarray(state, np.float64)
            t = max(t_lag, recent[-1].timestamp_s) if recent else t_lag
        pose = PoseEstimate(t, float(pred[0]), float(pred[1]), float(pred[2]), float(pred[3]),
                            float(pred[4]), float(pred[5]), np.asarray(cov, np.float64).copy())
        return MapState(t, pose, self._cones(), loop_closed=self.loop_closed,
                        backend=self.backend, map_frozen=self.map_frozen)


def slam_to_ukf_jacobian(ukf_x: np.ndarray, slam_dim: int, ukf_dim: int) -> np.ndarray:
    """(ukf_dim, slam_dim) Jacobian of the UKF's state (x, y, yaw, vx, vy, yaw rate[, gyro,
    accel x, accel y bias]) with respect to the SLAM's (x, y, yaw, world vx, world vy[, the same
    biases]) at the UKF's state ``ukf_x``: body velocities are the world ones rotated by -yaw;
    the yaw rate is the gyro less its bias."""
    T = np.zeros((ukf_dim, slam_dim))
    T[0, 0] = T[1, 1] = T[2, 2] = 1.0
    yaw, vx, vy = float(ukf_x[2]), float(ukf_x[3]), float(ukf_x[4])
    c, s = math.cos(yaw), math.sin(yaw)
    T[3, 3], T[3, 4], T[3, 2] = c, s, vy
    T[4, 3], T[4, 4], T[4, 2] = -s, c, -vx
    if slam_dim > 5 and ukf_dim >= N_STATE + N_BIAS:
        T[5, 5] = -1.0
        T[6, 5] = T[7, 6] = T[8, 7] = 1.0
    return T
