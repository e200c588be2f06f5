"""The Controller (Tier 2): the reactive layer, called at a fixed high rate.

Every tick: the safety supervisor checks the inputs and keeps the AS state; then the steering law
follows the plan's manoeuvre and the throttle and brake PIDs its target speed, or the car stops
(controlled at a set deceleration, or full braking at once). Measurements are passed in; nothing
here reads the world or the wall clock.
"""

from __future__ import annotations

import logging
import math

import numpy as np

from common.car import CarConfig
from common.messages import (
    ActuatorCommand,
    AsState,
    AsStatus,
    Health,
    Mission,
    Plan,
    PoseEstimate,
    RemoteStop,
)
from controller.as_state_machine import AsStateMachine
from controller.config import ControllerConfig
from controller.pid import PID, LongitudinalController, RateLimiter, clip
from controller.safety import (
    SafetyStatus,
    SafetySupervisor,
    StopKind,
    late_plan_cap_rate_mps2,
    late_plan_speed_mps,
    manoeuvre_ahead_m,
)
from controller.steering import (
    CurvaturePreview,
    HeadingP,
    Lookahead,
    PathRef,
    PurePursuit,
    Stanley,
    SteeringLaw,
)

logger = logging.getLogger(__name__)

PATH_MAX_AGE_S = 1.0
"""A plan's path is still steered along during a stop for this long (s)."""
DIP_SAMPLES = 6
"""Targets read between the car and the speed loop's preview point (``speed_dip_margin_mps``)."""


def make_steering_law(config: ControllerConfig, car: CarConfig) -> SteeringLaw:
    """The steering law named in the configuration."""
    look = Lookahead(config.lookahead_base_m, config.lookahead_time_s, config.lookahead_min_m,
                     config.lookahead_max_m)
    if config.steering_law == "stanley":
        return Stanley(car.wheelbase_m, config.stanley_k, config.stanley_soft_mps)
    if config.steering_law == "heading_p":
        return HeadingP(config.heading_kp, look)
    if config.steering_law == "preview":
        return CurvaturePreview(car.wheelbase_m, look, config.preview_time_s,
                                config.preview_damping)
    return PurePursuit(car.wheelbase_m, look)


def make_longitudinal(config: ControllerConfig, car: CarConfig) -> LongitudinalController:
    """Throttle and brake PIDs from the configuration."""
    t, b = config.throttle_pid, config.brake_pid
    return LongitudinalController(
        PID(t.kp, t.ki, t.kd, t.integral_limit, 0.0, 1.0),
        PID(b.kp, b.ki, b.kd, b.integral_limit, 0.0, 1.0),
        car.max_drive_accel_mps2,
        car.max_brake_decel_mps2,
        config.mode_switch_accel_mps2,
        config.resistance_accel_mps2,
        config.use_feedforward,
    )


class Controller:
    """Safety supervisor, steering law, throttle and brake PIDs (see the module docstring)."""

    def __init__(self, config: ControllerConfig, car: CarConfig, laps: int,
                 as_machine: AsStateMachine | None = None) -> None:
        """``laps``: autonomous laps before the car stops (the mission's, handed in by Main).
        ``as_machine``: the AS state machine, THE source of the AS state (Main builds it with
        the rules' timings and hands it the mission); None: the supervisor's stand-alone one
        (see :class:`~controller.safety.SafetySupervisor`)."""
        self.config = config
        self.car = car
        self.safety = SafetySupervisor(self.config.safety, laps, as_machine)
        self.longitudinal = make_longitudinal(self.config, self.car)
        self.steering_law = make_steering_law(self.config, self.car)
        self.steer_limiter = RateLimiter(min(self.config.max_steer_rate_radps,
                                             self.car.max_steer_rate_radps))
        self._last_t: float | None = None
        self._path_plan: Plan | None = None
        self._path: PathRef | None = None
        self._stop_t0 = math.nan
        self._stop_v0 = 0.0
        self._speed_mps = 0.0
        self._lock_speed_mps = math.inf
        """The speed (m/s) held while the steering law asks for the lock (inf: it does not)."""
        self.stop_speed_mps = math.nan
        """Speed (m/s) when the first stop was requested."""
        self.last_status: SafetyStatus | None = None

    # ------------------------------------------------------------------ state
    @property
    def state(self) -> AsState:
        """The AS state."""
        return self.safety.state

    @property
    def as_machine(self) -> AsStateMachine:
        """The AS state machine the supervisor steps."""
        return self.safety.machine

    def select_mission(self, mission: Mission | None) -> None:
        """The mission the car selects (``MISSION_SELECT``; None: none received)."""
        self.safety.select_mission(mission)

    def as_status(self, now_s: float) -> AsStatus:
        """The ``AS_STATUS`` to report at ``now_s``: AS state, mission, lap, ASSI mode."""
        return self.safety.machine.status(now_s)

    @property
    def stop_reason(self) -> str:
        """Why the car stopped (empty while it has not)."""
        return self.safety.stop_reason

    @property
    def stop_time_s(self) -> float:
        """When the first stop was requested (NaN if none)."""
        return self.safety.stop_time_s

    def arm(self, now_s: float) -> bool:
        """OFF -> READY."""
        return self.safety.arm(now_s)

    def go(self, now_s: float) -> bool:
        """READY -> DRIVING."""
        return self.safety.go(now_s)

    # ------------------------------------------------------------------ the tick
    def command(
        self,
        now_s: float,
        pose: PoseEstimate | None,
        plan: Plan | None,
        health: Health | None,
        remote: RemoteStop | None,
    ) -> ActuatorCommand:
        """The actuator command for this tick (never raises on bad input: it stops the car)."""
        cfg = self.config
        if self._last_t is None or not math.isfinite(now_s):
            dt = 1.0 / cfg.rate_hz
        else:
            dt = clip(now_s - self._last_t, 0.0, cfg.max_dt_s)
        if math.isfinite(now_s):
            self._last_t = now_s
        previous_stop = self.safety.stop
        status = self.safety.check(now_s, pose, plan, health, remote)
        self.last_status = status
        pose_ok = pose is not None and all(
            math.isfinite(v) for v in (pose.x_m, pose.y_m, pose.yaw_rad, pose.vx_mps))
        if pose_ok:
            assert pose is not None
            self._speed_mps = pose.vx_mps
        speed = self._speed_mps
        if status.stop != StopKind.NONE and previous_stop == StopKind.NONE:
            self.stop_speed_mps = speed
        path = self._path_for(plan, now_s)
        steer_target: float | None = None
        if pose_ok and path is not None:
            assert pose is not None
            yaw = pose.yaw_rad
            if cfg.steer_along_course and math.isfinite(pose.vy_mps) and speed > 1.0:
                yaw += math.atan2(pose.vy_mps, speed)
            steer_target = self.steering_law.update(pose.x_m, pose.y_m, yaw, speed, path)
            if math.isfinite(steer_target):
                # understeer: more steering per curvature as the lateral acceleration grows
                kappa = math.tan(steer_target) / self.car.wheelbase_m
                lateral = speed * speed * kappa
                steer_target += math.copysign(
                    float(np.interp(abs(lateral), cfg.understeer_accel_mps2,
                                    cfg.understeer_steer_rad)), lateral)
            else:
                steer_target = None
        throttle, brake = 0.0, 0.0
        state = status.state
        if state == AsState.OFF:
            self.longitudinal.reset()
        elif state in (AsState.READY, AsState.FINISHED) or (
                state == AsState.DRIVING and status.stop == StopKind.NONE
                and not self.safety.may_move(now_s)):
            # READY, FINISHED and the first seconds of DRIVING (the rules): the brake holds;
            # in DRIVING the wheels are turned to the path meanwhile (a car that starts in a
            # bend would otherwise roll ahead straight while its steering turns in)
            self.longitudinal.reset()
            brake = cfg.hold_brake
            if state != AsState.DRIVING:
                steer_target = None
        elif status.stop == StopKind.EMERGENCY or state == AsState.EMERGENCY:
            self.longitudinal.reset()
            brake = 1.0
        elif status.stop == StopKind.CONTROLLED:
            self.longitudinal.reset()
            brake = self._controlled_stop(now_s, speed, pose_ok)
            state = self.safety.state
        else:
            if path is None or not pose_ok:  # the supervisor stops the car next tick at latest
                brake = 1.0
            else:
                assert pose is not None and plan is not None
                v_cap, cap_rate = math.inf, 0.0
                if now_s - plan.timestamp_s > cfg.safety.plan_timeout_s:
                    # a late plan: no faster than its manoeuvre lets the car stop within it
                    safety = cfg.safety
                    v_cap = late_plan_speed_mps(
                        manoeuvre_ahead_m(plan.manoeuvre, pose.x_m, pose.y_m), safety,
                        safety.late_plan_slow_decel_mps2)
                    cap_rate = late_plan_cap_rate_mps2(speed, v_cap, safety)
                if self._at_lock(steer_target):
                    if not math.isfinite(self._lock_speed_mps):
                        self._lock_speed_mps = max(speed, cfg.lock_hold_min_speed_mps)
                    if self._lock_speed_mps < v_cap:
                        v_cap, cap_rate = self._lock_speed_mps, 0.0
                else:
                    self._lock_speed_mps = math.inf
                throttle, brake = self._speed_control(pose, path, speed, dt, v_cap, cap_rate)
        steer = steer_target if steer_target is not None else self.steer_limiter.value
        steer = clip(steer, -self.car.max_steer_rad, self.car.max_steer_rad)
        steer = self.steer_limiter.update(steer, dt)
        return self._safe_command(now_s, throttle, brake, steer, state)

    def _at_lock(self, steer_target: float | None) -> bool:
        """Whether the steering law asks for more than ``lock_hold_fraction`` of the lock (the
        speed is then held where it was when the law first asked for it,
        ``_lock_speed_mps``)."""
        fraction = self.config.lock_hold_fraction
        return (fraction > 0.0 and steer_target is not None
                and abs(steer_target) > fraction * self.car.max_steer_rad)

    def _path_for(self, plan: Plan | None, now_s: float) -> PathRef | None:
        if plan is None or len(plan.manoeuvre) < 2:
            return None
        if not now_s - plan.timestamp_s <= PATH_MAX_AGE_S:
            return None
        if plan is not self._path_plan:
            self._path_plan = plan
            self._path = PathRef.from_targets(plan.manoeuvre)
        return self._path

    def _speed_control(self, pose: PoseEstimate, path: PathRef, speed: float, dt: float,
                       v_cap_mps: float = math.inf, cap_rate_mps2: float = 0.0
                       ) -> tuple[float, float]:
        """(throttle, brake) toward the path's speed, no faster than ``v_cap_mps``; where the
        cap holds the reference, the planned acceleration is at most ``cap_rate_mps2`` (how
        fast the cap falls)."""
        cfg = self.config
        s_near, _ = path.nearest(pose.x_m, pose.y_m)
        s_ref = s_near + max(speed, 0.0) * cfg.speed_preview_s
        v_path = path.speed_at(s_ref)
        dip = False
        if cfg.speed_dip_margin_mps > 0.0:
            v_near = min(path.speed_at(float(s)) for s in np.linspace(s_near, s_ref, DIP_SAMPLES))
            dip = v_near < min(v_path, speed - cfg.speed_dip_margin_mps)
            if dip:
                v_path = v_near
        v_ref = min(v_path, v_cap_mps)
        span = max(speed * 0.5, 1.0)
        v_ahead = min(path.speed_at(s_ref + span), v_cap_mps)
        a_ff = (v_ahead * v_ahead - v_ref * v_ref) / (2.0 * span)
        if v_cap_mps < v_path:
            a_ff = min(a_ff, cap_rate_mps2)
        if dip:
            a_ff = min(a_ff, 0.0)
        return self.longitudinal.update(v_ref, speed, a_ff, dt)

    def _controlled_stop(self, now_s: float, speed: float, speed_known: bool) -> float:
        """Brake along a speed ramp at the set deceleration; at standstill hand over to the
        supervisor (FINISHED or EMERGENCY) and hold the brake. Without a speed measurement the
        car is taken to stand once the ramp has ended plus a second."""
        c = self.config.safety
        if not math.isfinite(self._stop_t0):
            self._stop_t0 = now_s
            self._stop_v0 = max(speed, 0.0)
        ramp_end_s = self._stop_t0 + self._stop_v0 / max(c.stop_decel_mps2, 1e-3)
        if speed <= c.standstill_speed_mps or (not speed_known and now_s > ramp_end_s + 1.0):
            self.safety.standstill(now_s)
            return self.config.hold_brake
        v_ref = max(self._stop_v0 - c.stop_decel_mps2 * (now_s - self._stop_t0), 0.0)
        decel = c.stop_decel_mps2 + (2.0 * (speed - v_ref) if speed_known else 0.0)
        return clip(decel / self.car.max_brake_decel_mps2, 0.1, 1.0)

    def _safe_command(self, now_s: float, throttle: float, brake: float, steer: float,
                      state: AsState) -> ActuatorCommand:
        values = (throttle, brake, steer)
        if not all(math.isfinite(v) for v in values) or not math.isfinite(now_s):
            logger.error("non-finite command (%s): full braking", values)
            t = now_s if math.isfinite(now_s) else 0.0
            return ActuatorCommand.full_brake(t, state)
        throttle = clip(throttle, 0.0, 1.0)
        brake = clip(brake, 0.0, 1.0)
        if brake > 0.0:
            throttle = 0.0
        return ActuatorCommand(now_s, throttle, brake, steer, state)
