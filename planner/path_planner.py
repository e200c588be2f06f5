"""The Path Planner (Tier 2): waypoint book, baseframe, manoeuvres, speed profile, laps.

Usage (the Main loop): :meth:`PathPlanner.observe` on every map update (records waypoints during
the exploration drive), :meth:`PathPlanner.start_autonomous` once when the autonomous laps begin
(builds the baseframe from one lap of waypoints, or from the cone map when there was no
exploration drive), then :meth:`PathPlanner.plan` at the planner rate.
"""

from __future__ import annotations

import collections
import logging
import math
from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from common.car import CarConfig
from common.errors import TrackError
from common.messages import Baseframe, MapState, Plan, PoseEstimate, TargetStates
from planner.baseframe import SplineBaseframe, centre_on_cones
from planner.boundary_walls import boundary_walls
from planner.config import PlannerConfig
from planner.exploration_path import ENTRY_BEHIND_M, exploration_path
from planner.exploration_speed import (
    exploring_curvature,
    exploring_speed_limit_mps,
    narrow_passage_limit_mps,
    passage_room_along_m,
    room_scaled_curvature,
    view_speed_mps,
    wide_lateral_factor,
)
from planner.explored_lap import ExploredLap
from planner.exploring_line import bends_beyond, steerable_frame
from planner.gate_search import coloured_ahead, has_colours
from planner.known_path import KNOWN_PATH_MISSIONS, KnownPathMission
from planner.lap_counter import LapCounter
from planner.manoeuvres import Candidate, ManoeuvreGenerator
from planner.race_job import BackgroundRace, RaceLine, build_race_line
from planner.seen_line import seen_racing_frame
from planner.speed_profile import (
    SpeedLimits,
    forward_backward_speed_mps,
    late_cover_table,
    steering_lock_cap,
    steering_rate_speed_limit_mps,
    two_level_speed_mps,
)
from planner.target_states import empty_targets, timed_targets
from planner.track_model import TrackModel, self_intersects
from planner.waypoints import WaypointBook, waypoints_from_cones

logger = logging.getLogger(__name__)

FloatArray = NDArray[np.float64]



class PathPlanner:
    """Plans the car's next manoeuvre from the map state (see the module docstring)."""

    def __init__(self, config: PlannerConfig, car: CarConfig, mission: str = "trackdrive",
                 stop_distance_m: Callable[[float], float] | None = None) -> None:
        """``mission``: the mission's name (``orchestrator.config.MISSIONS``); acceleration
        and skidpad are driven on a path known in advance (:mod:`planner.known_path`), the
        others on the track explored or mapped. ``stop_distance_m(speed_mps)``: the room (m)
        the safety supervisor wants a late plan to leave for a stop; manoeuvres at speed
        reach that far beyond ``late_cover_s`` of driving (:class:`ManoeuvreGenerator`)."""
        self.config = config
        self.car = car
        self.mission = mission
        c = self.config
        self.book = WaypointBook(c.waypoint_spacing_m, c.waypoint_reach_m, c.waypoints_served)
        self._race_worker = BackgroundRace() if c.racing_line_background else None
        self._lock_cap = steering_lock_cap(car, c.steer_lock_fraction, c.understeer_rad_per_mps2,
                                           c.crawl_speed_mps)
        self.generator = ManoeuvreGenerator(c, car, stop_distance_m)
        self._cover_room_m, self._cover_speed_mps = late_cover_table(stop_distance_m,
                                                                 c.exploration_late_cover_s)
        self.known = (KnownPathMission(mission, c, car) if mission in KNOWN_PATH_MISSIONS
                      else None)
        top_speed = c.acceleration_max_speed_mps if mission == "acceleration" else c.max_speed_mps
        lateral = c.skidpad_lateral_safety_factor if mission == "skidpad" \
            else c.lateral_safety_factor
        self.limits = SpeedLimits.from_car(car, c.friction_safety_factor, top_speed,
                                           lateral_factor=lateral)
        self.exploring_limits = SpeedLimits.from_car(
            car, c.friction_safety_factor, top_speed,
            lateral_factor=wide_lateral_factor(c))
        """The exploring profile's limits: the lateral one where the path has room, which the
        profile lowers where it has less (:func:`planner.exploration_speed.room_scaled_curvature`).
        A manoeuvre's own curvature keeps ``self.limits`` (its room is not measured: with
        these, ``hard:hairpins`` seed 2 passed a cone by 0.004 m instead of 0.032 m)."""
        self.frame: SplineBaseframe | None = None
        self.frame_source = ""
        self.track_model: TrackModel | None = None
        self._frame_msg: Baseframe | None = None
        self._speed_mps = np.zeros(0)
        self.autonomous = False
        self.laps = LapCounter(c.lap_min_fraction, c.start_line_search_m)
        self._last_offset: float | None = None
        self._last_chosen: Candidate | None = None
        self._hold: tuple[float, float] | None = None
        """(until (s), speed (m/s)): no plan asks more speed until then (``fallback_hold_s``)."""
        self._origin_xy: tuple[float, float] | None = None
        """Where the autonomous run started when it explores (no exploration drive)."""
        self._explored: ExploredLap | None = None
        """The car's progress while it explores (distance, start-line crossings, trace)."""
        self.rejects: collections.Counter[str] = collections.Counter()
        self.views_ahead_m: list[float] = []
        """The seen track ahead of the car (m) at each exploring plan (:meth:`explored_view`)."""

    @property
    def lap(self) -> int:
        """Laps done (:class:`planner.lap_counter.LapCounter`; exploring, the explored lap's
        start-line crossings; 1 once a known path's run is done)."""
        return self.laps.lap

    @lap.setter
    def lap(self, value: int) -> None:
        self.laps.lap = value

    # ------------------------------------------------------------------ phases
    def observe(self, map_state: MapState) -> None:
        """Record a waypoint from the estimated pose (exploration drive only)."""
        self.observe_pose(map_state.pose)

    def observe_pose(self, pose: PoseEstimate) -> None:
        """Record a waypoint from ``pose`` (exploration drive only)."""
        if self.autonomous:
            return
        if not self.book.record(pose.x_m, pose.y_m) and not (
            math.isfinite(pose.x_m) and math.isfinite(pose.y_m)
        ):
            self.rejects["non_finite_pose"] += 1

    def start_autonomous(self, map_state: MapState) -> None:
        """Build the baseframe and start the autonomous laps.

        One closed lap of recorded waypoints when the exploration drive came back to its start,
        an open frame through them when it did not (e.g. acceleration); with no exploration drive
        waypoints from the cone map. A failure is logged and counted; :meth:`plan` then keeps
        trying from the cone map.
        """
        self.autonomous = True
        if self.known is not None:
            pose = map_state.pose
            if all(math.isfinite(v) for v in (pose.x_m, pose.y_m, pose.yaw_rad)):
                self.known.start(pose.x_m, pose.y_m, pose.yaw_rad)
            self._known_frame(map_state)
            self._reset_progress(map_state)
            return
        if len(self.book) >= 8:
            closed = self.book.close_loop(self.config.loop_close_distance_m,
                                          self.config.min_loop_length_m,
                                          self.config.loop_bridge_max_m)
            if not closed:
                logger.info("exploration drive did not close a lap: an open baseframe")
            self._build_frame(self.book.points_xy_m, closed, "waypoints", map_state)
        if self.frame is None:
            pose = map_state.pose
            if math.isfinite(pose.x_m) and math.isfinite(pose.y_m):
                self._origin_xy = (pose.x_m, pose.y_m)
                self._explored = ExploredLap(self._origin_xy, pose.yaw_rad, self.config)
                logger.info("no exploration drive: exploring from the cones as they are mapped")
            self._frame_from_cones(map_state)
        self._reset_progress(map_state)

    def explore(self, map_state: MapState) -> bool:
        """The local planner's call while exploring: the distance driven and laps counted so
        far, then the baseframe (``frame``) from the cones mapped so far, ordered into the
        track ahead of the car (a loop that passes the start closes it). True when a frame was
        made; what :meth:`plan` does first each call while exploring."""
        self._count_exploration(map_state)
        return self._frame_from_cones(map_state)

    def _count_exploration(self, map_state: MapState) -> None:
        pose = map_state.pose
        if self._explored is not None and (self.frame is None or not self.frame.closed):
            self._explored.update(pose.x_m, pose.y_m, map_state)
            self.lap = max(self.lap, self._explored.laps)

    @property
    def exploring(self) -> bool:
        """Planning from the cones mapped so far on an open track (the first lap, explored)."""
        return self.autonomous and self.frame_source == "cones" and (
            self.frame is None or not self.frame.closed)

    def explored_view(self) -> tuple[float, float] | None:
        """(the median seen track ahead of the car (m) over the exploring plans, the speed
        (m/s) the invariant allows with that much in view on a straight); None before any
        exploring plan or with no stop rule handed in."""
        if not self.views_ahead_m or len(self._cover_room_m) == 0:
            return None
        view_m = float(np.median(self.views_ahead_m))
        return view_m, view_speed_mps(view_m, self._cover_room_m, self._cover_speed_mps)

    # ------------------------------------------------------------------ frame building
    def _build_frame(
        self, points: FloatArray, closed: bool, source: str, map_state: MapState
    ) -> bool:
        c = self.config
        exploring = source == "cones" and not closed and self._origin_xy is not None
        try:
            frame = SplineBaseframe(points, closed, resample_m=c.baseframe_resample_m,
                                    smoothing_m=c.baseframe_smoothing_m,
                                    step_m=c.baseframe_step_m,
                                    sigma_per_radius=c.smoothing_per_radius)
            cones = map_state.cones
            raced = None
            if closed and len(cones) >= 8 and not self_intersects(frame.xy_m, True):
                raced = self._race_frame(frame, map_state)
            if raced is not None:
                frame = raced
            elif exploring:  # where the gates' path bends beyond the lock (exploring_line)
                car_xy = (map_state.pose.x_m, map_state.pose.y_m)
                steered = steerable_frame(frame, cones.xy_m, cones.colour, car_xy, self.car, c,
                                          self.generator.kappa_max_1pm)
                if (steered is None and c.exploration_line_room_m > 0.0
                        and not bends_beyond(frame, frame.project(*car_xy)[0]
                                             + c.exploration_start_m,
                                             self.generator.kappa_max_1pm)
                        and has_colours(cones.colour)):
                    # (where the gates' path bends beyond the lock the cones seen may leave
                    # the line room across a hairpin's infield: EUFS Hairpin seed 3; with no
                    # colour in the map the gates are guessed, and so is the room beside them)
                    previous = self.frame if self.frame_source == "cones" else None
                    steered = seen_racing_frame(frame, cones.xy_m, self.generator.circle_offsets_m,
                                                self.generator.required_m,
                                                c.exploration_line_room_m, c, car_xy, previous)
                frame = steered or frame
            elif c.centre_on_cones and len(cones) >= 8:
                # (an explored path runs through the gates' middles already; centring it on
                # every cone within reach also pulls it toward another stretch of the track)
                frame = centre_on_cones(frame, cones.xy_m, cones.colour,
                                        max_shift_m=c.max_centring_shift_m,
                                        resample_m=c.baseframe_resample_m,
                                        smoothing_m=c.baseframe_smoothing_m,
                                        step_m=c.baseframe_step_m)
        except (TrackError, ValueError) as exc:
            self.rejects["baseframe"] += 1
            logger.warning("baseframe from %s failed: %s", source, exc)
            return False
        self.frame = frame
        self.frame_source = source
        self._frame_msg = frame.to_message()
        self._speed_mps = self._profile(frame, car_xy=(map_state.pose.x_m, map_state.pose.y_m),
                                        cones_xy_m=map_state.cones.xy_m)
        if source == "waypoints":
            self.book.set_points(frame.xy_m[:: max(int(c.waypoint_spacing_m / frame.step_m), 1)],
                                 closed)
        (logger.debug if self.exploring else logger.info)(
            "baseframe from %s: %.1f m, closed=%s", source, frame.length_m, closed)
        return True

    def _race_frame(self, guide: SplineBaseframe, map_state: MapState) -> SplineBaseframe | None:
        """The racing line inside the track the map's cones mark along ``guide`` (a lap), as a
        baseframe; None (logged) when the cones do not make a track, or when it is being built
        in the background (``racing_line_background``: :meth:`plan` swaps it in when done)."""
        c = self.config
        cones = map_state.cones
        if self._race_worker is not None:
            self._race_worker.submit(cones.xy_m, cones.colour, guide.xy_m, c, self.car,
                                     self.limits)
            logger.info("racing line: being built in the background; the centre line meanwhile")
            return None
        try:
            return self._race_line_frame(build_race_line(cones.xy_m, cones.colour, guide.xy_m,
                                                         c, self.car, self.limits))
        except (TrackError, ValueError) as exc:
            self.rejects["track_model"] += 1
            logger.warning("track model from the cone map failed (%s): the guide's frame", exc)
            return None

    def _race_line_frame(self, race: RaceLine) -> SplineBaseframe:
        """The baseframe along a built racing line (its track model kept)."""
        c = self.config
        frame = SplineBaseframe(race.line_xy_m, True, resample_m=c.baseframe_resample_m,
                                smoothing_m=c.racing_line_smoothing_m, step_m=c.baseframe_step_m)
        self.track_model = race.model
        return frame

    def _take_race_line(self, map_state: MapState) -> None:
        """Swap in the racing line built in the background, once it is done: the laps and the
        car's place in the lap carry over to it."""
        assert self._race_worker is not None
        result = self._race_worker.poll()
        if result is None:
            return
        if isinstance(result, BaseException):
            self.rejects["track_model"] += 1
            logger.warning("track model from the cone map failed (%s): the centre line stays",
                           result)
            return
        try:
            frame = self._race_line_frame(result)
        except (TrackError, ValueError) as exc:
            self.rejects["track_model"] += 1
            logger.warning("racing line's baseframe failed (%s): the centre line stays", exc)
            return
        old, lap = self.frame, self.lap
        laps_done = self.laps.laps_done(old)  # laps past the start, with the fraction
        self.frame = frame
        self._frame_msg = frame.to_message()
        self._speed_mps = self._profile(frame)
        self._reset_progress(map_state)
        if old is not None and old.closed and laps_done is not None:
            self.laps.carry_over(frame, laps_done)
        self.lap = max(lap, self.lap)
        logger.info("racing line swapped in: %.1f m, lap %d", frame.length_m, self.lap)

    def close(self) -> None:
        """Stop the racing line's background process, if any."""
        if self._race_worker is not None:
            self._race_worker.close()
            self._race_worker = None

    def _frame_from_cones(self, map_state: MapState) -> bool:
        c = self.config
        pose = map_state.pose
        if not all(math.isfinite(v) for v in (pose.x_m, pose.y_m, pose.yaw_rad)):
            return False
        min_loop_m = c.min_loop_length_m
        if self._explored is not None and self._explored.laps >= 1:
            # a lap counted at the start line: the loop may be as short as a lap may be
            min_loop_m = min(min_loop_m, c.lap_min_m)
        explored = self._explored
        if explored is not None and explored.loop_search_pointless(pose.x_m, pose.y_m,
                                                                   min_loop_m, self.mission):
            pts, closed = np.zeros((0, 2)), False
        else:
            pts, closed = waypoints_from_cones(
                map_state.cones.xy_m, map_state.cones.colour, (pose.x_m, pose.y_m),
                pose.yaw_rad, min_pair_m=c.min_cone_pair_distance_m,
                max_pair_m=c.max_cone_pair_distance_m, track_width_m=c.nominal_track_width_m,
                max_step_m=c.waypoint_max_step_m, max_turn_rad=c.waypoint_max_turn_rad,
                min_loop_length_m=min_loop_m,
            )
        if closed and explored is not None:
            refusal = explored.loop_refusal(pts, self.mission)
            if refusal:
                self.rejects[refusal] += 1
                logger.debug("a loop in the cones, not the track (%s): still exploring", refusal)
                closed = False
        if not closed and self._origin_xy is not None:
            # exploring: the gates ahead of the car, as far as the cones are known
            driven = self._explored.driven_behind() if self._explored is not None else None
            pts = exploration_path(map_state.cones.xy_m, map_state.cones.colour,
                                   (pose.x_m, pose.y_m), pose.yaw_rad,
                                   track_width_m=c.nominal_track_width_m, behind_m=ENTRY_BEHIND_M,
                                   driven_xy_m=driven)
            if len(pts) < 3:  # a gate or two: from the car itself
                pts = exploration_path(map_state.cones.xy_m, map_state.cones.colour,
                                       (pose.x_m, pose.y_m), pose.yaw_rad,
                                       track_width_m=c.nominal_track_width_m, driven_xy_m=driven)
            if len(pts) == 2:  # one gate: a straight line to it
                pts = pts[0] + np.linspace(0.0, 1.0, 4)[:, None] * (pts[1] - pts[0])
        if len(pts) < 3:
            self.rejects["no_track_in_cones"] += 1
            return False
        ok = self._build_frame(pts, closed, "cones", map_state)
        if ok and not closed:
            self.book.set_points(pts, closed=False)
        return ok

    def _known_frame(self, map_state: MapState) -> bool:
        """The baseframe of a known-path mission from the map as it is now, when the map has
        grown since the last one (True when a new frame was made)."""
        assert self.known is not None
        if self.known.start_pose is None:
            pose = map_state.pose
            if not all(math.isfinite(v) for v in (pose.x_m, pose.y_m, pose.yaw_rad)):
                return False
            self.known.start(pose.x_m, pose.y_m, pose.yaw_rad)
        path = self.known.build(map_state)
        if path is None:
            return False
        c = self.config
        try:
            frame = SplineBaseframe(path.points_xy_m, False, resample_m=c.baseframe_resample_m,
                                    smoothing_m=c.baseframe_smoothing_m,
                                    step_m=c.baseframe_step_m)
        except (TrackError, ValueError) as exc:
            self.rejects["baseframe"] += 1
            logger.warning("%s baseframe failed: %s", self.known.mission, exc)
            return False
        self.frame = frame
        self.frame_source = self.known.mission
        self._frame_msg = frame.to_message()
        self._speed_mps = self._profile(
            frame, self.known.stop_s_m(KnownPathMission.scale(frame.length_m, path)))
        return True

    def _profile(self, frame: SplineBaseframe, stop_s_m: float = math.inf,
                 car_xy: tuple[float, float] | None = None,
                 cones_xy_m: FloatArray | None = None) -> FloatArray:
        """The speed profile (M,) (m/s) along ``frame``; an open frame ends at standstill,
        at ``stop_s_m`` (m along it) when that comes first."""
        c = self.config
        ds = np.full(len(frame.s_m) if frame.closed else len(frame.s_m) - 1, frame.step_m)
        kappa = rate_kappa = frame.curvature_1pm
        exploring = not frame.closed and self._origin_xy is not None
        if exploring:
            # the path through the gates starts at the car: its first metres bend from where
            # the car is to the middle of the track, which the manoeuvre does, checked against
            # its own curvature; the speed comes from the track's bends beyond
            kappa, rate_kappa = exploring_curvature(kappa, frame.step_m, c)
        extra = steering_rate_speed_limit_mps(
            rate_kappa, frame.step_m, self.car.wheelbase_m,
            c.steer_rate_fraction * self.car.max_steer_rate_radps,
            c.understeer_rad_per_mps2, frame.closed)
        extra = np.minimum(extra, self._lock_cap(kappa))
        if c.speed_mode == "two_level":
            extra = np.minimum(extra, two_level_speed_mps(
                frame.s_m, frame.heading_rad, frame.closed, frame.length_m,
                c.two_level_fast_mps, c.two_level_slow_mps, c.two_level_turn_rad,
                c.two_level_preview_m))
        v_end = None if frame.closed else 0.0
        if exploring:  # the invariant: able to stop within the track seen (exploration_speed)
            limit, v_end, view_m = exploring_speed_limit_mps(
                frame, car_xy, self._cover_room_m, self._cover_speed_mps, c,
                self.limits.brake_mps2)
            if car_xy is not None:
                self.views_ahead_m.append(view_m)
            extra = np.minimum(extra, limit)
            room = passage_room_along_m(frame, cones_xy_m, self.generator, c)
            extra = np.minimum(extra, narrow_passage_limit_mps(frame, cones_xy_m,
                                                               self.generator, c, room))
            kappa = room_scaled_curvature(kappa, room, c, frame.step_m)
        if math.isfinite(stop_s_m):
            extra = np.where(frame.s_m >= stop_s_m, 0.0, extra)
        limits = self.exploring_limits if exploring else self.limits
        return forward_backward_speed_mps(kappa, ds, limits, frame.closed,
                                          v_end_mps=v_end, v_limit_mps=extra)

    def speed_at(self, s_m: FloatArray) -> FloatArray:
        """The baseframe speed profile (m/s) at arc lengths ``s_m``."""
        assert self.frame is not None
        if self.frame.closed:
            return np.asarray(np.interp(s_m, self.frame.s_m, self._speed_mps,
                                        period=self.frame.length_m), np.float64)
        return np.asarray(np.interp(s_m, self.frame.s_m, self._speed_mps), np.float64)

    # ------------------------------------------------------------------ laps
    def _reset_progress(self, map_state: MapState) -> None:
        self._last_chosen = None
        explored_m = self._explored.explored_m if self._explored is not None else 0.0
        self.laps.reset(self.frame, map_state, self._origin_xy, explored_m)

    # ------------------------------------------------------------------ planning
    def plan(self, map_state: MapState, now_s: float) -> Plan:
        """The next manoeuvre from the map state's pose, as timed target states."""
        pose = map_state.pose
        finite = all(math.isfinite(v) for v in (pose.x_m, pose.y_m, pose.yaw_rad, pose.vx_mps))
        if not finite:
            self.rejects["non_finite_pose"] += 1
            logger.warning("plan: non-finite pose rejected")
            return self._empty_plan(now_s)
        self._count_exploration(map_state)
        if self._race_worker is not None and self._race_worker.pending:
            self._take_race_line(map_state)
        if self.known is not None:
            if self._known_frame(map_state) and self.laps.s_hint_m is None:
                self._reset_progress(map_state)
        elif self.frame is None or (self.frame_source == "cones" and not self.frame.closed):
            self._frame_from_cones(map_state)
            if self.frame is not None and self.frame.closed:
                self._reset_progress(map_state)
        frame = self.frame
        if frame is None:
            return self._empty_plan(now_s)
        if frame.closed or self.laps.s_hint_m is not None:
            s0, d0 = frame.project(pose.x_m, pose.y_m, self.laps.s_hint_m,
                                   self.config.projection_window_m)
            if abs(d0) > 6.0:  # lost the branch: search everywhere
                s0, d0 = frame.project(pose.x_m, pose.y_m)
        else:
            s0, d0 = frame.project(pose.x_m, pose.y_m)
        self.laps.update(frame, s0)
        self.laps.s_hint_m = s0
        if self.known is not None and self.known.path is not None and self.known.update(
                s0, KnownPathMission.scale(frame.length_m, self.known.path), pose.speed_mps):
            self.lap = 1  # the mission's one "lap": the controller stops the car, finished
        cones = map_state.cones.xy_m
        near = np.hypot(cones[:, 0] - pose.x_m, cones[:, 1] - pose.y_m)
        # a lap mapped: the camera's tentative cones (ids < 0) add only their range errors
        seen = (map_state.cones.ids >= 0) | (not frame.closed)
        cones = cones[(near < self.config.cone_search_radius_m) & seen]
        speed = pose.speed_mps
        walls = boundary_walls(frame, map_state.cones.xy_m, map_state.cones.colour,
                               (pose.x_m, pose.y_m)) if self.exploring else None
        cands, best = self.generator.generate(frame, s0, d0, pose.yaw_rad, speed, cones,
                                              self._last_offset, self._stitch(frame, s0, d0),
                                              speed_margin=self.exploring, walls=walls,
                                              far_conflicts=coloured_ahead(
                                                  map_state.cones.xy_m, map_state.cones.colour,
                                                  (pose.x_m, pose.y_m), pose.yaw_rad,
                                                  self.config.horizon_max_m))
        waypoints = self.book.next_waypoints(pose.x_m, pose.y_m)
        if not cands:
            return self._empty_plan(now_s, waypoints)
        cap = self._held_speed_mps(now_s)
        if best >= 0:
            chosen = cands[best]
            self._last_offset = chosen.offset_m
            self._last_chosen = chosen
            targets = self._targets(chosen, now_s, stop=False, cap_mps=cap)
            if chosen.speed_cap_mps < speed:
                self._start_hold(now_s, speed)
        else:
            self.rejects["no_feasible_manoeuvre"] += 1
            self._last_chosen = None
            fallback = self.generator.stop_path(cands, speed**2 / (2.0 * self.limits.brake_mps2))
            logger.warning("no feasible manoeuvre at s=%.1f m: stopping (on the candidate: "
                           "%s; rejected so far: %s)", s0, cands[fallback].reason,
                           dict(self.generator.rejections))
            targets = self._targets(cands[fallback], now_s, stop=True)
            self._start_hold(now_s, speed)
        return Plan(
            timestamp_s=now_s,
            baseframe=self._frame_msg,
            manoeuvre=targets,
            target_speed_mps=float(targets.speed_mps[0]) if len(targets) else 0.0,
            candidates=tuple(cand.xy_m for cand in cands),
            chosen_index=best,
            waypoints_xy_m=waypoints,
            lap=self.lap,
        )

    def _stitch(self, frame: SplineBaseframe, s0: float, d0: float) -> tuple[float, float] | None:
        """The previous plan's Frenet offset and slope at ``s0`` when the car is within
        ``stitch_tolerance_m`` of it (the new plan continues the old one); None to start from
        the car (first plan, a jump of the pose, or the car far off the plan)."""
        last = self._last_chosen
        tol = self.config.stitch_tolerance_m
        if last is None or tol <= 0.0 or len(last.s_m) < 3:
            return None
        u = s0 - float(last.s_m[0])
        if frame.closed:
            u = u % frame.length_m
        span = float(last.s_m[-1] - last.s_m[0])
        if not 0.0 <= u <= 0.5 * span:
            return None
        uu = last.s_m - last.s_m[0]
        d_prev = float(np.interp(u, uu, last.d_m))
        slope = float(np.interp(u, uu, np.gradient(last.d_m, uu)))
        if abs(d0 - d_prev) > tol:
            self.rejects["replan_from_car"] += 1
            return None
        return d_prev, slope

    def _start_hold(self, now_s: float, speed_mps: float) -> None:
        """A fallback brakes the car at ``speed_mps``: hold the plans to that speed (or to the
        speed of a hold already on, if less) for ``fallback_hold_s``, never below
        ``fallback_speed_mps``: at the fallbacks' own pace a hold has nothing to hold back, and
        one ratcheted down by the crawls of a hairpin left the car at walking pace."""
        c = self.config
        if c.fallback_hold_s <= 0.0 or speed_mps <= c.fallback_speed_mps:
            return
        held = min(speed_mps, self._held_speed_mps(now_s))
        self._hold = (now_s + c.fallback_hold_s, max(held, c.fallback_speed_mps))

    def _held_speed_mps(self, now_s: float) -> float:
        """The speed (m/s) a fallback's hold allows at ``now_s``; inf with none on."""
        if self._hold is None or now_s >= self._hold[0]:
            return math.inf
        return self._hold[1]

    def _targets(self, cand: Candidate, now_s: float, stop: bool,
                 cap_mps: float = math.inf) -> TargetStates:
        """Discretise a candidate into timed target states with friction-limited speeds, no
        faster than ``cap_mps``."""
        return timed_targets(cand, self.speed_at, self.limits, now_s, stop,
                             self.config.min_plan_speed_mps, cap_mps)

    def _empty_plan(self, now_s: float, waypoints: FloatArray | None = None) -> Plan:
        return Plan(
            timestamp_s=now_s,
            baseframe=self._frame_msg,
            manoeuvre=empty_targets(),
            target_speed_mps=0.0,
            waypoints_xy_m=np.zeros((0, 2)) if waypoints is None else waypoints,
            lap=self.lap,
        )

