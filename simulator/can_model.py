"""The car's CAN bus as the simulator sees it: wheel speeds and steering angle at 100 Hz, the
RES state and the selected mission (``MISSION_SELECT``, :meth:`CanModel.set_mission`) at
10 Hz, encoded through ``sensors/car.dbc`` (so quantised exactly as on the car).

Wheel surface speeds come from the true planar motion: each wheel's velocity (the vehicle origin
is the rear-axle centre; front wheels at the wheelbase, steered by the true steering angle)
projected on the wheel's heading, times ``1 + N(0, wheel_slip_sigma)`` (slip), plus
``N(0, wheel_noise_mps)`` while rolling; a wheel at rest reads 0 like a Hall-effect sensor.

Faults: :meth:`CanModel.set_res` (the ``estop`` fault presses the emergency stop);
``garbage = True`` (the ``can-garbage`` fault) adds, per 10 ms tick, frames of ids the DBC does
not know and frames of known ids with a wrong length.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from common.messages import (
    CanFrame,
    GroundTruth,
    Mission,
    MissionSelect,
    RemoteStop,
    SteeringAngle,
    WheelSpeeds,
)
from sensors.can_codec import CanCodec
from simulator.config import WorldConfig


class CanModel:
    """Emits the CAN frames due up to each ``poll`` time, deterministic for a given ``rng``.

    Rates (Hz) and noise are keyword arguments; the defaults are the car's.
    """

    def __init__(self, config: WorldConfig, rng: np.random.Generator, *,
                 wheel_rate_hz: float = 100.0, steer_rate_hz: float = 100.0,
                 res_rate_hz: float = 10.0, mission_rate_hz: float = 10.0,
                 wheel_slip_sigma: float = 0.01,
                 wheel_noise_mps: float = 0.02, steer_noise_rad: float = 0.002,
                 garbage_per_tick: float = 2.0) -> None:
        self.config = config
        self.car = config.car
        self.rng = rng
        self.codec = CanCodec(config.sensors.can.dbc or None)
        self.wheel_period_s = 1.0 / wheel_rate_hz
        self.steer_period_s = 1.0 / steer_rate_hz
        self.res_period_s = 1.0 / res_rate_hz
        self.mission_period_s = 1.0 / mission_rate_hz
        self.mission_value: int | None = None
        """The wire value ``MISSION_SELECT`` carries (None: no frame is sent)."""
        self.wheel_slip_sigma = wheel_slip_sigma
        self.wheel_noise_mps = wheel_noise_mps
        self.steer_noise_rad = steer_noise_rad
        self.garbage_per_tick = garbage_per_tick
        self.garbage = False
        self.emergency = False
        self.go = True
        self._known_ids = {m.frame_id: m.length for m in self.codec.db.messages}
        self._next_wheel_k = 0
        self._next_steer_k = 0
        self._next_res_k = 0
        self._next_mission_k = 0
        self._next_garbage_k = 0
        self._started = False

    def set_res(self, emergency: bool, go: bool) -> None:
        """The state the RES frames report from now on."""
        self.emergency = bool(emergency)
        self.go = bool(go)

    def set_mission(self, value: int | None) -> None:
        """The wire value the ``MISSION_SELECT`` frames carry from now on (a
        :class:`~common.messages.Mission` or any number 0..15; None: send none)."""
        self.mission_value = None if value is None else int(value)

    # -- physics --------------------------------------------------------------------------

    def true_wheel_speeds(self, truth: GroundTruth, vehicle: Any = None) -> tuple[float, ...]:
        """Noise-free wheel surface speeds (m/s) FL, FR, RL, RR.

        Uses ``vehicle.wheel_speeds_mps()`` (or the attribute) when the vehicle model provides
        it, else the rigid-body kinematics of ``truth`` (velocities at the rear-axle origin).
        """
        provided = getattr(vehicle, "wheel_speeds_mps", None) if vehicle is not None else None
        if provided is not None:
            values = provided() if callable(provided) else provided
            try:
                speeds = tuple(float(v) for v in values)
            except TypeError:
                speeds = ()
            if len(speeds) == 4:
                return speeds
        half = 0.5 * self.car.track_width_m
        length = self.car.wheelbase_m
        r = truth.yaw_rate_radps
        vx, vy = truth.vx_mps, truth.vy_mps
        delta = truth.steering_rad
        c, s = math.cos(delta), math.sin(delta)
        out = []
        for x, y, steered in ((length, half, True), (length, -half, True),
                              (0.0, half, False), (0.0, -half, False)):
            ux = vx - r * y
            uy = vy + r * x
            out.append(ux * c + uy * s if steered else ux)
        return tuple(out)

    # -- frames ---------------------------------------------------------------------------

    def _wheel_frame(self, t_s: float, truth: GroundTruth, vehicle: Any) -> CanFrame:
        true = np.asarray(self.true_wheel_speeds(truth, vehicle))
        measured = true * (1.0 + self.wheel_slip_sigma * self.rng.standard_normal(4))
        measured += self.wheel_noise_mps * self.rng.standard_normal(4)
        measured = np.where(np.abs(true) < 1e-3, 0.0, measured)
        ws = WheelSpeeds(t_s, *(float(v) for v in measured))
        return self.codec.encode_wheel_speeds(ws)

    def _steer_frame(self, t_s: float, truth: GroundTruth) -> CanFrame:
        angle = truth.steering_rad + self.steer_noise_rad * float(self.rng.standard_normal())
        return self.codec.encode_steering(SteeringAngle(t_s, angle))

    def _mission_frame(self, t_s: float, value: int) -> CanFrame:
        known = {m.value for m in Mission}
        mission = Mission(value) if value in known else Mission.UNKNOWN
        frame = self.codec.encode_mission(MissionSelect(t_s, mission, value))
        if value in known:
            return frame
        data = bytearray(frame.data)  # a wire value outside the table: written as it is
        data[0] = (data[0] & 0xF0) | (value & 0x0F)
        return CanFrame(frame.timestamp_s, frame.arbitration_id, bytes(data))

    def _garbage_frames(self, t_s: float) -> list[CanFrame]:
        frames = []
        for _ in range(int(self.rng.poisson(self.garbage_per_tick))):
            if self.rng.random() < 0.5:
                fid = int(self.rng.integers(0, 0x800))
                while fid in self._known_ids:
                    fid = int(self.rng.integers(0, 0x800))
                length = int(self.rng.integers(0, 9))
            else:
                ids = sorted(self._known_ids)
                fid = ids[int(self.rng.integers(0, len(ids)))]
                length = int(self.rng.integers(0, 9))
                if length == self._known_ids[fid]:
                    length = (length + 1) % 9
            data = self.rng.integers(0, 256, size=length, dtype=np.uint8).tobytes()
            frames.append(CanFrame(t_s, fid, data))
        return frames

    def poll(self, t_s: float, truth: GroundTruth, vehicle: Any = None,
             track: Any = None) -> list[CanFrame]:
        """Every frame due in (last poll, ``t_s``], in time order, stamped at its tick time.

        ``truth`` is the state at ``t_s`` (the simulator polls at its physics rate, so it is at
        most one physics step old for each frame).
        """
        due: list[tuple[float, int, list[CanFrame]]] = []
        eps = 1e-9
        if not self._started:  # the first poll starts the schedules at its own time
            self._started = True
            self._next_wheel_k = math.ceil(t_s / self.wheel_period_s - eps)
            self._next_steer_k = math.ceil(t_s / self.steer_period_s - eps)
            self._next_res_k = math.ceil(t_s / self.res_period_s - eps)
            self._next_mission_k = math.ceil(t_s / self.mission_period_s - eps)
            self._next_garbage_k = self._next_wheel_k
        while self._next_wheel_k * self.wheel_period_s <= t_s + eps:
            tk = self._next_wheel_k * self.wheel_period_s
            due.append((tk, 1, [self._wheel_frame(tk, truth, vehicle)]))
            self._next_wheel_k += 1
        while self._next_steer_k * self.steer_period_s <= t_s + eps:
            tk = self._next_steer_k * self.steer_period_s
            due.append((tk, 2, [self._steer_frame(tk, truth)]))
            self._next_steer_k += 1
        while self._next_res_k * self.res_period_s <= t_s + eps:
            tk = self._next_res_k * self.res_period_s
            due.append((tk, 0, [self.codec.encode_res(RemoteStop(tk, self.emergency, self.go))]))
            self._next_res_k += 1
        while self._next_mission_k * self.mission_period_s <= t_s + eps:
            tk = self._next_mission_k * self.mission_period_s
            if self.mission_value is not None:
                due.append((tk, 4, [self._mission_frame(tk, self.mission_value)]))
            self._next_mission_k += 1
        while self._next_garbage_k * self.wheel_period_s <= t_s + eps:
            tk = self._next_garbage_k * self.wheel_period_s
            if self.garbage:
                due.append((tk, 3, self._garbage_frames(tk)))
            self._next_garbage_k += 1
        due.sort(key=lambda item: (item[0], item[1]))
        return [frame for _, _, frames in due for frame in frames]
