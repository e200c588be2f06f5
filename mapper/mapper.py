"""The Mapper (Tier 2): readings in, :class:`MapState` out.

While the car explores, a mapping backend (``mapper.backend``) maps and gives the pose, behind
one small protocol (:mod:`mapper.backend`):

- ``slam``: seed 000's EKF SLAM (:mod:`mapper.slam_backend`); the UKF waits;
- ``smoother``: seed 002's pipeline, the UKF of seed 001 giving the pose and the time smoother
  merging the LiDAR objects put in the world (:mod:`mapper.smoother_backend`).

Each closes the loop by its own rule; the map is then frozen (``MapState.map_frozen``) and the
car localises on it with the UKF and its cone update (:mod:`mapper.map_localiser`). Camera
cones bring colour (a vote per associated detection); LiDAR brings position. The Mapper keeps
what is common: the delay buffer, the object filter, the GNSS world frame, the odometer and the
pose predicted to now.

Timing (seed 000, 6.2.1): readings are applied in the order they were made through a
:class:`~mapper.delay_buffer.DelayBuffer`; the output pose is the lagged estimate predicted
forward to the newest IMU sample. An :meth:`Mapper.update` call with a few readings costs one
short prediction and no map work; the heavy work happens once per LiDAR sweep.
"""

from __future__ import annotations

import logging
import math
from collections import Counter, deque
from collections.abc import Sequence

import numpy as np

from common.car import CarConfig
from common.conventions import LocalTangentFrame, WorldFrame, vehicle_to_world, wrap_angle
from common.messages import (
    CameraCones,
    ConeColour,
    ConeDetection,
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
from mapper.backend import Estimator, MappingBackend
from mapper.colour_votes import without_colours
from mapper.config import MapperConfig
from mapper.delay_buffer import DelayBuffer
from mapper.gnss_frame import GnssFrameEstimator
from mapper.gnss_timing import GnssTiming
from mapper.imu_coalesce import coalesce_imu
from mapper.imu_mount import ImuMount
from mapper.map_localiser import MapLocaliser
from mapper.motion import predict_forward
from mapper.object_filter import ObjectFilter
from mapper.slam_backend import SlamBackend
from mapper.smoother_backend import SmootherBackend
from mapper.tentative_cones import TentativeCones, with_tentative
from mapper.time_smoother import N_COLOURS
from mapper.ukf_localiser import UkfLocaliser
from mapper.wheel_scale import WheelScaleEstimator

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

    ``backend`` maps during the exploration, ``localiser`` localises on the frozen map after;
    ``world_frame`` is the GNSS world frame once known (else None); ``stats`` counts applied,
    rejected and skipped measurements per sensor.
    """

    def __init__(self, config: MapperConfig, car: CarConfig,
                 start_heading_enu_rad: float | None = None,
                 localisation_only: bool = False) -> None:
        """``start_heading_enu_rad``: the world frame's heading in ENU (rad) when it is known
        (the mission's; None: estimated from the GNSS course). ``localisation_only``: no cones
        to map (a road drive): the UKF localises from the start on an empty map, in the ENU
        frame of the first fix (the world frame), started at the first fix with a course
        (:attr:`initialised`)."""
        self.config = config
        self.car = car
        self.start_heading_enu_rad = start_heading_enu_rad
        self.ukf = UkfLocaliser(config.ukf, car)
        self.backend: MappingBackend = (
            SlamBackend(config, car, self.ukf, self._count) if config.backend == "slam"
            else SmootherBackend(config, car, self.ukf))
        self.localiser: MapLocaliser | None = None
        self.object_filter = ObjectFilter(config.object_filter)
        self.buffer = DelayBuffer(config.fusion.max_delay_s, config.fusion.freeze_gap_s)
        self.world_frame: WorldFrame | None = None
        self._enu: LocalTangentFrame | None = None
        self._frame_estimator: GnssFrameEstimator | None = None
        self._steer: SteeringAngle | None = None
        self._last_wheels_s: float | None = None
        self._recent_imu: deque[ImuSample] = deque()
        self.odometer_m = 0.0
        """Travel by the rear wheels (m)."""
        self.loop_closed = False
        self._cones_cache: ConeMap = ConeMap.empty()
        self._cones_dirty = False
        self._positions_dirty = False
        """The landmarks moved since the cone map was last built (a colour vote alone does not
        move them: the tentative cones need only where the landmarks are)."""
        self.tentative = TentativeCones(config.tentative)
        """Camera cones beyond the landmarks, published while exploring
        (:mod:`mapper.tentative_cones`)."""
        self._published: tuple[ConeMap, ConeMap] | None = None
        """(the landmarks, the landmarks with the tentative cones) last published."""
        self._camera_last_s = -math.inf
        """Time (s) of the newest camera frame: colours go with it (``fusion.colour_stale_s``)."""
        self._counts: dict[str, Counter[str]] = {}
        self._state = MapState(0.0, PoseEstimate(0.0, 0.0, 0.0, 0.0), ConeMap.empty(),
                               backend=self.backend.name)
        self._mount = ImuMount(car)
        self._gnss_timing = GnssTiming(config.ukf.gnss_latency_s, config.ukf.gnss_time_from_utc)
        self.wheel_scale = (WheelScaleEstimator(config.ukf.odometry_speed_scale)
                            if config.ukf.odometry_scale_from_gnss else None)
        self._last_rear_mps = math.nan
        self.localisation_only = localisation_only
        self.initialised = not localisation_only
        """False until the localisation-only UKF was started at a fix (always True else)."""
        if localisation_only:
            self.localiser = MapLocaliser(self.ukf, ConeMap.empty(),
                                          config.fusion.colour_gate_m)

    @property
    def map_frozen(self) -> bool:
        """The map is fixed and the UKF localises on it."""
        return self.localiser is not None

    @property
    def estimator(self) -> Estimator:
        """Whoever takes the readings now: the backend, then the localiser."""
        return self.localiser if self.localiser is not None else self.backend

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
            if isinstance(r, ImuSample):
                r = self._mount.apply(r)
            elif isinstance(r, GpsFix):
                r = self._gnss_timing.retime(r)
            if self.buffer.push(stream, r, now_s) and isinstance(r, ImuSample):
                self._recent_imu.append(r)
        ready, merged = coalesce_imu(self.buffer.pop_ready(now_s),
                                     self.config.fusion.imu_coalesce_backlog_s)
        if merged:
            self._counts.setdefault("imu", Counter())["coalesced"] += merged
        for stream, r in ready:
            try:
                self._apply(r)
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
        cone_map = known_map if known_map is not None else self.estimator.cone_map()
        own_map = self.backend.owns_map_errors and known_map is None
        if self.localiser is None:
            cone_map = self.backend.hand_over(cone_map, own_map)
            if own_map:
                self._refine_gnss_frame()
        if not own_map and (self.localiser is None or cone_map is not self.localiser.map):
            # A surveyed map or the smoother's: independent cones, each with its covariance.
            self.ukf.set_map(cone_map)
        self.localiser = MapLocaliser(self.ukf, cone_map, self.config.fusion.colour_gate_m)
        self._cones_dirty = True
        self.tentative.clear()
        self._published = None
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
        if self.buffer.freezes:
            out["fusion"] = {"freezes": self.buffer.freezes}
        if self.object_filter.rejects:
            out["object_filter"] = dict(self.object_filter.rejects)
        out.update(self.backend.stats())
        return out

    def _refine_gnss_frame(self) -> None:
        """At the freeze: the frame heading from every course of the exploration lap against the
        backend's yaw (:meth:`GnssFrameEstimator.heading_estimate`); the UKF's offset state
        starts at zero with its sigma."""
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

    def _apply(self, r: Reading) -> None:
        if isinstance(r, ImuSample):
            self.estimator.predict(r)
        elif isinstance(r, WheelSpeeds):
            if self._last_wheels_s is not None:
                dt = r.timestamp_s - self._last_wheels_s
                if 0.0 < dt < 1.0:
                    self.odometer_m += abs(r.mean_rear_mps) * dt
            self._last_wheels_s = r.timestamp_s
            self._last_rear_mps = r.mean_rear_mps
            self.estimator.update_odometry(r, self._steer)
        elif isinstance(r, SteeringAngle):
            self._steer = r
        elif isinstance(r, GpsFix):
            self._on_gps(r)
        elif isinstance(r, LidarCones):
            cones = self.object_filter.filter(r.cones)
            result = self.estimator.update_lidar(cones, r.timestamp_s, self.odometer_m)
            self._cones_dirty |= result.map_changed
            self._positions_dirty |= result.map_changed
            if result.loop_closed:
                self.loop_closed = True
                self.freeze()
        elif isinstance(r, CameraCones):
            self._camera_last_s = max(self._camera_last_s, r.timestamp_s)
            cones = [c for c in r.cones
                     if math.isfinite(c.x_m) and math.isfinite(c.y_m)
                     and int(ConeColour.UNKNOWN) < int(c.colour) < N_COLOURS]
            if cones:
                self._cones_dirty |= self.estimator.add_colours(cones)
                if self.config.tentative.enabled and not self.map_frozen:
                    self._add_tentative(cones, r.timestamp_s)

    def _on_gps(self, fix: GpsFix) -> None:
        cfg = self.config.ukf
        if self.wheel_scale is not None:
            self.ukf.wheel_scale = self.wheel_scale.add(fix.timestamp_s, fix.speed_mps,
                                                     self._last_rear_mps)
        if fix.fix_quality == 0 or not (math.isfinite(fix.lat_deg)
                                        and math.isfinite(fix.lon_deg)):
            self._count("gnss", "rejected_invalid")
            return
        if self.localisation_only:
            self._on_gps_localising(fix)
            return
        if self._enu is None:
            alt = fix.altitude_m if math.isfinite(fix.altitude_m) else 0.0
            self._enu = LocalTangentFrame(fix.lat_deg, fix.lon_deg, alt)
            self._frame_estimator = GnssFrameEstimator(
                self._enu, self.start_heading_enu_rad, cfg.heading_estimate_samples,
                cfg.gnss_min_speed_mps, cfg.track_alignment_distance_m,
                max_yaw_rate_radps=cfg.heading_estimate_max_yaw_rate_radps,
                yaw_error_correlation_s=cfg.heading_yaw_error_correlation_s,
                alignment_heading_sigma_rad=cfg.track_alignment_heading_sigma_rad)
        e, n, _ = self._enu.to_enu(fix.lat_deg, fix.lon_deg, self._enu.alt0_m)
        east, north = float(e), float(n)
        estimator = self._frame_estimator
        assert estimator is not None
        refining = self.localiser is None and self.backend.refines_gnss_frame
        if self.world_frame is None or refining:
            # Until the frame is found, and on with the SLAM's yaw for the refinement at the
            # freeze (not with the UKF's: once it takes courses its yaw leans on them).
            p = self.estimator.pose()
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
        self.estimator.update_gnss(xy, fix, self.world_frame)

    def _on_gps_localising(self, fix: GpsFix) -> None:
        """Localisation only: the world frame is the ENU frame of the first fix; the UKF starts
        at the first fix with a course (above ``gnss_min_speed_mps``), the antenna
        ``gnss_antenna_x_m`` ahead of the rear axle along the course."""
        cfg = self.config.ukf
        if self._enu is None:
            alt = fix.altitude_m if math.isfinite(fix.altitude_m) else 0.0
            self._enu = LocalTangentFrame(fix.lat_deg, fix.lon_deg, alt)
            self.world_frame = WorldFrame(self._enu)
        assert self.world_frame is not None
        e, n, _ = self._enu.to_enu(fix.lat_deg, fix.lon_deg, self._enu.alt0_m)
        xy = np.array([float(e), float(n)])
        if self.initialised:
            self.estimator.update_gnss(xy, fix, self.world_frame)
            return
        if not (math.isfinite(fix.course_rad) and math.isfinite(fix.speed_mps)
                and fix.speed_mps >= cfg.gnss_min_speed_mps):
            self._count("gnss", "waiting_for_course")
            return
        yaw = fix.course_rad
        a = cfg.gnss_antenna_x_m
        sigma_yaw = max(cfg.gnss_speed_sigma_mps / fix.speed_mps, cfg.gnss_track_sigma_floor_rad)
        cov = np.diag([cfg.gnss_position_sigma_m**2, cfg.gnss_position_sigma_m**2,
                       sigma_yaw**2])
        self.ukf.reset(PoseEstimate(fix.timestamp_s, float(xy[0]) - a * math.cos(yaw),
                                    float(xy[1]) - a * math.sin(yaw), yaw, fix.speed_mps,
                                    0.0, 0.0, cov))
        self.initialised = True
        self._count("gnss", "started")
        log.info("localisation started at %.3f s: E %.2f N %.2f m, course %.4f rad, %.2f m/s",
                 fix.timestamp_s, xy[0], xy[1], yaw, fix.speed_mps)

    # -- output -------------------------------------------------------------------------------

    def _cones(self) -> ConeMap:
        if self._cones_dirty:
            self._cones_dirty = self._positions_dirty = False
            self._cones_cache = self.estimator.cone_map()
        return self._cones_cache

    def _add_tentative(self, cones: Sequence[ConeDetection], t_s: float) -> None:
        """A camera frame's cones (vehicle frame at ``t_s``, colours known) to the tentative
        cones, at the estimator's pose of that time."""
        pose = self.estimator.pose()
        xy = np.array([(c.x_m, c.y_m) for c in cones], np.float64)
        world = vehicle_to_world(xy, pose.x_m, pose.y_m, pose.yaw_rad).reshape(-1, 2)
        landmarks = self._cones() if self._positions_dirty else self._cones_cache
        self.tentative.add(world, np.array([int(c.colour) for c in cones], np.int64),
                           np.array([c.confidence for c in cones], np.float64), t_s,
                           landmarks.xy_m, (pose.x_m, pose.y_m))
        self._published = None

    def _published_cones(self) -> ConeMap:
        """The landmarks, and while exploring the tentative cones after them."""
        landmarks = self._cones()
        if self.map_frozen or not self.config.tentative.enabled:
            return landmarks
        if self._published is None or self._published[0] is not landmarks:
            self._published = (landmarks, with_tentative(
                landmarks, self.tentative.cone_map(landmarks.xy_m)))
        return self._published[1]

    def _cones_to_publish(self, now_s: float) -> ConeMap:
        """:meth:`_published_cones`; but while exploring with a camera silent for longer than
        ``fusion.colour_stale_s`` (s, on the caller's clock ``now_s``) after it has reported,
        the landmarks alone, none of them coloured: the colours and the tentative cones were
        the camera's."""
        if (not self.map_frozen and math.isfinite(self._camera_last_s)
                and now_s - self._camera_last_s > self.config.fusion.colour_stale_s):
            return without_colours(self._cones())
        return self._published_cones()

    def _make_state(self, now_s: float) -> MapState:
        lagged = self.estimator.lagged(now_s)
        recent = self._recent_imu
        while recent and recent[0].timestamp_s <= lagged.t_s:
            recent.popleft()
        bg, bax, bay = lagged.imu_bias
        gyro_bias, accel_bias = bg, np.array([bax, bay])
        if recent and not lagged.calibrating:
            pred, t = predict_forward(lagged.state, lagged.t_s, recent, gyro_bias, accel_bias,
                                      self.car.imu_x_m)
        else:  # standing still (calibrating) or nothing newer: the lagged state holds
            pred = np.asarray(lagged.state, np.float64)
            t = max(lagged.t_s, recent[-1].timestamp_s) if recent else lagged.t_s
        pose = PoseEstimate(t, float(pred[0]), float(pred[1]), float(pred[2]), float(pred[3]),
                            float(pred[4]), float(pred[5]),
                            np.asarray(lagged.covariance, np.float64).copy())
        return MapState(t, pose, self._cones_to_publish(now_s), loop_closed=self.loop_closed,
                        backend=self.backend.name, map_frozen=self.map_frozen)
