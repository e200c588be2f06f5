"""Tiny controllers in the style of openpilot's ``common/pid.py``: state in, number out.

Measurements are passed in; nothing here reads the world or the time.
"""

from __future__ import annotations

import math


def clip(value: float, low: float, high: float) -> float:
    """``value`` limited to [low, high]."""
    return low if value < low else high if value > high else value


class PID:
    """A PID with a clipped integrator and a clipped output, derivative on the measurement.

    ``integral_limit`` bounds the integrator's contribution ``ki * integral``; the integrator also
    stops growing while the output is saturated in the direction it would push (anti-windup).
    """

    def __init__(
        self,
        kp: float,
        ki: float = 0.0,
        kd: float = 0.0,
        integral_limit: float = math.inf,
        output_min: float = 0.0,
        output_max: float = 1.0,
    ) -> None:
        self.kp, self.ki, self.kd = kp, ki, kd
        self.integral_limit = integral_limit
        self.output_min, self.output_max = output_min, output_max
        self.integral = 0.0
        self.p = self.i = self.d = self.f = 0.0
        self._last_measurement: float | None = None

    def reset(self) -> None:
        """Forget the integral and the last measurement."""
        self.integral = 0.0
        self.p = self.i = self.d = self.f = 0.0
        self._last_measurement = None

    def update(
        self, setpoint: float, measurement: float, dt_s: float, feedforward: float = 0.0
    ) -> float:
        """One step: the output for ``setpoint`` and ``measurement`` after ``dt_s`` seconds."""
        error = setpoint - measurement
        self.p = self.kp * error
        self.f = feedforward
        if self._last_measurement is not None and dt_s > 0.0:
            self.d = -self.kd * (measurement - self._last_measurement) / dt_s
        else:
            self.d = 0.0
        self._last_measurement = measurement
        if self.ki != 0.0 and dt_s > 0.0:
            candidate = self.integral + error * dt_s
            limit = self.integral_limit / abs(self.ki)
            candidate = clip(candidate, -limit, limit)
            unclipped = self.p + self.ki * candidate + self.d + self.f
            pushing_up = unclipped > self.output_max and error > 0.0
            pushing_down = unclipped < self.output_min and error < 0.0
            if not (pushing_up or pushing_down):
                self.integral = candidate
        self.i = self.ki * self.integral
        return clip(self.p + self.i + self.d + self.f, self.output_min, self.output_max)


class RateLimiter:
    """Limits how fast a value may change: at most ``max_rate`` per second."""

    def __init__(self, max_rate: float, initial: float = 0.0) -> None:
        self.max_rate = max_rate
        self.value = initial

    def reset(self, value: float = 0.0) -> None:
        """Start again from ``value``."""
        self.value = value

    def update(self, target: float, dt_s: float) -> float:
        """Move toward ``target`` by at most ``max_rate * dt_s``."""
        step = self.max_rate * max(dt_s, 0.0)
        self.value += clip(target - self.value, -step, step)
        return self.value


class LongitudinalController:
    """Seed 002's speed control: a PID for the throttle and a PID for the brake.

    Only one of them is active at a time (throttle and brake are never both above zero); the
    mode switches on the wanted acceleration with a hysteresis. ``feedforward`` uses the planned
    acceleration scaled by the car's drive and brake limits.
    """

    def __init__(
        self,
        throttle: PID,
        brake: PID,
        max_drive_accel_mps2: float,
        max_brake_decel_mps2: float,
        switch_accel_mps2: float = 0.4,
        resistance_accel_mps2: float = 0.3,
        use_feedforward: bool = True,
    ) -> None:
        self.throttle_pid = throttle
        self.brake_pid = brake
        self.max_drive = max_drive_accel_mps2
        self.max_brake = max_brake_decel_mps2
        self.switch = switch_accel_mps2
        self.resistance = resistance_accel_mps2
        self.use_feedforward = use_feedforward
        self.braking = False

    def reset(self) -> None:
        """Both PIDs reset, throttle mode."""
        self.throttle_pid.reset()
        self.brake_pid.reset()
        self.braking = False

    def update(
        self, speed_ref_mps: float, speed_mps: float, accel_ref_mps2: float, dt_s: float
    ) -> tuple[float, float]:
        """(throttle, brake), each 0..1, never both above zero."""
        a_ff = accel_ref_mps2 if self.use_feedforward else 0.0
        wanted = a_ff + self.throttle_pid.kp * self.max_drive * (speed_ref_mps - speed_mps)
        if self.braking and wanted > self.switch:
            self.braking = False
            self.brake_pid.reset()
        elif not self.braking and wanted < -self.switch:
            self.braking = True
            self.throttle_pid.reset()
        if self.braking:
            ff = max(-a_ff, 0.0) / self.max_brake
            brake = self.brake_pid.update(-speed_ref_mps, -speed_mps, dt_s, ff)
            return 0.0, brake
        ff = 0.0
        if self.use_feedforward:
            resist = self.resistance if speed_ref_mps > 0.5 else 0.0
            ff = max(a_ff + resist, 0.0) / self.max_drive
        throttle = self.throttle_pid.update(speed_ref_mps, speed_mps, dt_s, ff)
        return throttle, 0.0
