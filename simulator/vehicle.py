"""The simulated car: a dynamic bicycle model with a tyre friction limit.

State is kept at the vehicle origin (the rear-axle centre, :mod:`common.conventions`): world
position and yaw, vehicle-frame velocity ``vx_mps`` (forward) and ``vy_mps`` (left), yaw rate.

Model (per step ``dt_s``, explicit Euler, meant for >= 200 Hz):
- Steering actuator: first-order lag ``car.steer_lag_s`` towards the command, rate-limited to
  ``car.max_steer_rate_radps`` and clamped to ``+-car.max_steer_rad`` (road-wheel angle).
- Longitudinal: throttle 0..1 asks ``throttle * car.max_drive_accel_mps2`` (faded out over the
  last 10 % below ``car.top_speed_mps``), brake 0..1 asks ``brake * car.max_brake_decel_mps2``
  against the motion; rolling resistance and aerodynamic drag. Forces are split over the axles
  by their static loads (all-wheel drive and braking), so no axle locks before the other.
- Tyres: lateral force ``F = F_avail * tanh(C * alpha / F_avail)`` per axle (linear cornering
  stiffness ``C`` at small slip, saturating), with the friction circle
  ``F_avail = sqrt((mu Fz)^2 - Fx^2)`` and ``mu = car.max_lateral_accel_mps2 / g``: at the
  limit the car cannot corner harder than ``max_lateral_accel_mps2``.
- Below 3 m/s the state blends to the kinematic bicycle (no tyre slip), so the model is stable
  at walking pace and at rest. The car never rolls backwards (no reverse gear).

Pure-Python scalar maths: a step costs a few microseconds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from common.car import CarConfig
from common.messages import ActuatorCommand, GroundTruth
from common.polyline import FloatArray

GRAVITY_MPS2 = 9.81
ROLLING_RESISTANCE_MPS2 = 0.15
"""Deceleration from rolling resistance while moving (m/s^2)."""
DRAG_PER_M = 0.0015
"""Aerodynamic drag deceleration per speed squared (1/m): 0.6 m/s^2 at 20 m/s."""
FRONT_STIFFNESS_PER_LOAD = 10.0
"""Front cornering stiffness per unit axle load (N/rad per N)."""
REAR_STIFFNESS_PER_LOAD = 14.0
"""Rear cornering stiffness per unit axle load: stiffer than the front, so the car understeers."""
FRONT_GRIP_FACTOR = 0.9
"""The front axle's friction coefficient relative to the rear: the front saturates first, so at
the limit the car runs wide (understeer) instead of spinning."""
SLIP_AT_FULL_GRIP = 0.03
"""Longitudinal wheel slip when an axle uses all its grip for drive or braking."""
KINEMATIC_BELOW_MPS = 1.5
DYNAMIC_ABOVE_MPS = 3.0
KINEMATIC_LAG_S = 0.03
"""Time constant (s) with which the low-speed state follows the kinematic bicycle."""


@dataclass(slots=True)
class VehicleState:
    """The car's state at the vehicle origin (rear-axle centre).

    Position (m) and yaw (rad) in the world frame; ``vx_mps``/``vy_mps`` velocity of the origin
    in the vehicle frame; ``ax_mps2``/``ay_mps2`` acceleration of the origin in the vehicle
    frame (inertial, without gravity); ``yaw_accel_radps2``; ``steer_rad`` road-wheel angle;
    wheel surface speeds (m/s); ``distance_m`` travelled; ``t_s`` simulated time.
    """

    x_m: float = 0.0
    y_m: float = 0.0
    yaw_rad: float = 0.0
    vx_mps: float = 0.0
    vy_mps: float = 0.0
    yaw_rate_radps: float = 0.0
    steer_rad: float = 0.0
    ax_mps2: float = 0.0
    ay_mps2: float = 0.0
    yaw_accel_radps2: float = 0.0
    wheel_fl_mps: float = 0.0
    wheel_fr_mps: float = 0.0
    wheel_rl_mps: float = 0.0
    wheel_rr_mps: float = 0.0
    distance_m: float = 0.0
    t_s: float = 0.0

    @property
    def speed_mps(self) -> float:
        """Speed of the vehicle origin over ground (m/s)."""
        return math.hypot(self.vx_mps, self.vy_mps)


class Vehicle:
    """The simulated car (see the module docstring for the model)."""

    def __init__(self, car: CarConfig, x_m: float = 0.0, y_m: float = 0.0,
                 yaw_rad: float = 0.0) -> None:
        self.car = car
        self.state = VehicleState(x_m=x_m, y_m=y_m, yaw_rad=yaw_rad)
        self.wheelbase_m = car.wheelbase_m
        self.lf_m = car.cg_to_front_axle_m
        self.lr_m = car.wheelbase_m - car.cg_to_front_axle_m
        self.mass_kg = car.mass_kg
        self.iz_kgm2 = car.yaw_inertia_kgm2
        self.mu = car.max_lateral_accel_mps2 / GRAVITY_MPS2
        weight = car.mass_kg * GRAVITY_MPS2
        self.fz_front_n = weight * self.lr_m / car.wheelbase_m
        self.fz_rear_n = weight * self.lf_m / car.wheelbase_m
        self.c_front = FRONT_STIFFNESS_PER_LOAD * self.fz_front_n
        self.c_rear = REAR_STIFFNESS_PER_LOAD * self.fz_rear_n
        self._vy_cg = 0.0
        self._fx_front_n = 0.0
        self._fx_rear_n = 0.0
        self._fy_front_n = 0.0
        self._fy_rear_n = 0.0
        self._front_m = car.length_m - car.rear_overhang_m
        self._rear_m = -car.rear_overhang_m
        self._half_width_m = 0.5 * car.width_m

    # -- stepping -----------------------------------------------------------------------------

    def step(self, command: ActuatorCommand | None, dt_s: float) -> None:
        """Advance the state by ``dt_s`` (s) under ``command`` (None: coast, wheels held)."""
        st = self.state
        car = self.car
        if dt_s <= 0.0:
            return
        if command is None:
            throttle, brake, steer_cmd = 0.0, 0.0, st.steer_rad
        else:
            throttle, brake, steer_cmd = command.throttle, command.brake, command.steering_rad
        max_steer = car.max_steer_rad
        # steering actuator: lag, rate limit, clamp
        steer_cmd = min(max(steer_cmd, -max_steer), max_steer)
        lag = max(car.steer_lag_s, 1e-6)
        rate = (steer_cmd - st.steer_rad) / lag
        max_rate = car.max_steer_rate_radps
        rate = min(max(rate, -max_rate), max_rate)
        step_steer = rate * dt_s
        if abs(step_steer) > abs(steer_cmd - st.steer_rad):
            step_steer = steer_cmd - st.steer_rad
        delta = min(max(st.steer_rad + step_steer, -max_steer), max_steer)
        st.steer_rad = delta

        vx = st.vx_mps
        r = st.yaw_rate_radps
        vy_cg = self._vy_cg
        lf, lr, wb = self.lf_m, self.lr_m, self.wheelbase_m
        m = self.mass_kg

        # longitudinal demand (total force, N)
        a_drive = 0.0
        if throttle > 0.0:
            fade = (car.top_speed_mps - vx) / (0.1 * car.top_speed_mps)
            a_drive = throttle * car.max_drive_accel_mps2 * min(max(fade, 0.0), 1.0)
        a_brake = brake * car.max_brake_decel_mps2
        if vx > 0.0:
            fx_total = m * (a_drive - a_brake)
        elif vx < 0.0:
            fx_total = m * (a_drive + a_brake)
        else:
            fx_total = m * a_drive
        fx_f = fx_total * lr / wb
        fx_r = fx_total * lf / wb
        fmax_f = self.mu * FRONT_GRIP_FACTOR * self.fz_front_n
        fmax_r = self.mu * self.fz_rear_n
        fx_f = min(max(fx_f, -fmax_f), fmax_f)
        fx_r = min(max(fx_r, -fmax_r), fmax_r)
        resist = math.copysign(ROLLING_RESISTANCE_MPS2 + DRAG_PER_M * vx * vx, vx) \
            if vx != 0.0 else 0.0

        speed = math.sqrt(vx * vx + vy_cg * vy_cg)
        w = (speed - KINEMATIC_BELOW_MPS) / (DYNAMIC_ABOVE_MPS - KINEMATIC_BELOW_MPS)
        w = min(max(w, 0.0), 1.0)
        cos_d, sin_d = math.cos(delta), math.sin(delta)
        tan_d = sin_d / cos_d

        fy_f = fy_r = 0.0
        if w > 0.0:
            alpha_f = delta - math.atan2(vy_cg + lf * r, vx)
            alpha_r = -math.atan2(vy_cg - lr * r, vx)
            avail_f = math.sqrt(max(fmax_f * fmax_f - fx_f * fx_f, 1.0))
            avail_r = math.sqrt(max(fmax_r * fmax_r - fx_r * fx_r, 1.0))
            fy_f = avail_f * math.tanh(self.c_front * alpha_f / avail_f)
            fy_r = avail_r * math.tanh(self.c_rear * alpha_r / avail_r)
            dvx_dyn = (fx_f * cos_d - fy_f * sin_d + fx_r) / m + r * vy_cg - resist
            dvy_dyn = (fx_f * sin_d + fy_f * cos_d + fy_r) / m - r * vx
            dr_dyn = (lf * (fy_f * cos_d + fx_f * sin_d) - lr * fy_r) / self.iz_kgm2
            vx_dyn = vx + dvx_dyn * dt_s
            vy_dyn = vy_cg + dvy_dyn * dt_s
            r_dyn = r + dr_dyn * dt_s
        else:
            vx_dyn = vy_dyn = r_dyn = 0.0
        # kinematic bicycle (no slip: the rear axle has no lateral velocity); vy and r relax
        # to it within KINEMATIC_LAG_S, never faster than the tyres' grip allows
        dvx_kin = (fx_f * cos_d + fx_r) / m - resist
        vx_kin = max(vx + dvx_kin * dt_s, 0.0)
        if w < 1.0:
            r_target = vx_kin * tan_d / wb
            lim = self.mu * GRAVITY_MPS2
            dvy_kin = min(max((r_target * lr - vy_cg) / KINEMATIC_LAG_S, -lim), lim)
            dr_kin = min(max((r_target - r) / KINEMATIC_LAG_S, -lim / lr), lim / lr)
            vy_kin = vy_cg + dvy_kin * dt_s
            r_kin = r + dr_kin * dt_s
        else:
            r_kin = vy_kin = 0.0
        new_vx = w * vx_dyn + (1.0 - w) * vx_kin
        new_vy = w * vy_dyn + (1.0 - w) * vy_kin
        new_r = w * r_dyn + (1.0 - w) * r_kin
        if new_vx < 0.0 and w < 1.0:
            # at low speed brakes and resistance stop the car; they never reverse it (a car
            # spinning fast may slide backwards: that is left to the dynamic model)
            new_vx = 0.0

        dvx = (new_vx - vx) / dt_s
        dvy = (new_vy - vy_cg) / dt_s
        dr = (new_r - r) / dt_s
        # acceleration of the CG in the vehicle frame, then of the origin (rear axle)
        ax_cg = dvx - r * vy_cg
        ay_cg = dvy + r * vx
        st.ax_mps2 = ax_cg + r * r * lr
        st.ay_mps2 = ay_cg - dr * lr
        st.yaw_accel_radps2 = dr

        # integrate the pose with the mean of old and new velocities (rear-axle point)
        vy_ra_old = vy_cg - lr * r
        vy_ra_new = new_vy - lr * new_r
        ux = 0.5 * (vx + new_vx)
        uy = 0.5 * (vy_ra_old + vy_ra_new)
        yaw_mid = st.yaw_rad + 0.5 * (r + new_r) * 0.5 * dt_s
        c, s = math.cos(yaw_mid), math.sin(yaw_mid)
        st.x_m += (ux * c - uy * s) * dt_s
        st.y_m += (ux * s + uy * c) * dt_s
        yaw = st.yaw_rad + 0.5 * (r + new_r) * dt_s
        if yaw > math.pi or yaw <= -math.pi:
            yaw = math.atan2(math.sin(yaw), math.cos(yaw))
        st.yaw_rad = yaw
        st.distance_m += math.hypot(ux, uy) * dt_s

        self._vy_cg = new_vy
        st.vx_mps = new_vx
        st.vy_mps = vy_ra_new
        st.yaw_rate_radps = new_r
        st.t_s += dt_s
        self._fx_front_n, self._fx_rear_n = fx_f, fx_r
        self._fy_front_n, self._fy_rear_n = fy_f, fy_r
        self._update_wheels(cos_d, sin_d)

    def _update_wheels(self, cos_d: float, sin_d: float) -> None:
        st = self.state
        half = 0.5 * self.car.track_width_m
        vx, vy, r = st.vx_mps, st.vy_mps, st.yaw_rate_radps
        wb = self.wheelbase_m
        slip_f = SLIP_AT_FULL_GRIP * self._fx_front_n / (self.mu * self.fz_front_n)
        slip_r = SLIP_AT_FULL_GRIP * self._fx_rear_n / (self.mu * self.fz_rear_n)
        uy_front = vy + r * wb
        fl = ((vx - r * half) * cos_d + uy_front * sin_d) * (1.0 + slip_f)
        fr = ((vx + r * half) * cos_d + uy_front * sin_d) * (1.0 + slip_f)
        rl = (vx - r * half) * (1.0 + slip_r)
        rr = (vx + r * half) * (1.0 + slip_r)
        st.wheel_fl_mps = max(fl, 0.0)
        st.wheel_fr_mps = max(fr, 0.0)
        st.wheel_rl_mps = max(rl, 0.0)
        st.wheel_rr_mps = max(rr, 0.0)

    # -- outputs ------------------------------------------------------------------------------

    def wheel_speeds_mps(self) -> tuple[float, float, float, float]:
        """Wheel surface speeds (m/s): front-left, front-right, rear-left, rear-right."""
        st = self.state
        return st.wheel_fl_mps, st.wheel_fr_mps, st.wheel_rl_mps, st.wheel_rr_mps

    def accel_at(self, x_m: float, y_m: float = 0.0) -> tuple[float, float]:
        """Inertial acceleration (m/s^2, vehicle frame, no gravity) of the body point at
        (x_m, y_m) in the vehicle frame (e.g. the IMU at car.imu_x_m)."""
        st = self.state
        r, dr = st.yaw_rate_radps, st.yaw_accel_radps2
        return (st.ax_mps2 - dr * y_m - r * r * x_m, st.ay_mps2 + dr * x_m - r * r * y_m)

    def truth(self, t_s: float | None = None) -> GroundTruth:
        """The true state as a :class:`GroundTruth` (at ``t_s``, default the model's time)."""
        st = self.state
        return GroundTruth(st.t_s if t_s is None else t_s, st.x_m, st.y_m, st.yaw_rad,
                           st.vx_mps, st.vy_mps, st.yaw_rate_radps, st.steer_rad)

    def footprint_corners(self) -> list[tuple[float, float]]:
        """The car's outline corners in the world frame (m): rear-left, rear-right,
        front-right, front-left."""
        st = self.state
        c, s = math.cos(st.yaw_rad), math.sin(st.yaw_rad)
        out = []
        for px, py in ((self._rear_m, self._half_width_m), (self._rear_m, -self._half_width_m),
                       (self._front_m, -self._half_width_m), (self._front_m, self._half_width_m)):
            out.append((st.x_m + px * c - py * s, st.y_m + px * s + py * c))
        return out

    def footprint_xy_m(self) -> FloatArray:
        """:meth:`footprint_corners` as a (4,2) array."""
        return np.array(self.footprint_corners(), np.float64)
