"""Simulated IMU: VectorNav binary packets (sensors/imu_protocol.py) at 200 Hz.

The IMU sits on the car's centre line ``car.imu_x_m`` ahead of the vehicle origin (the
rear-axle centre), aligned with the vehicle frame, on flat ground. It measures, in the vehicle
frame (x forward, y left, z up):

- specific force: the acceleration of its mounting point plus gravity's reaction,
  ``a_z = +9.81``; in the plane, ``vehicle.accel_at(imu_x_m, 0)`` when the vehicle model
  provides it (simulator.vehicle.Vehicle does), else from the ground truth
  ``a_x = dvx/dt - r vy - r^2 d``, ``a_y = dvy/dt + r vx + dr/dt d`` (``d`` = imu_x_m, time
  derivatives by backward differences between successive polls);
- angular rate ``(0, 0, r)``;

each plus a bias (a constant drawn per run, ``config.sim.imu.*_bias_sigma_*``, plus a random
walk :attr:`ImuNoise.accel_bias_walk` / ``gyro_bias_walk``) and white noise
(``config.sim.imu.accel_sigma_mps2`` / ``gyro_sigma_radps``). The packet carries the sensor's
own time since power-on (``ImuNoise.startup_offset_s`` before the simulation started).

Faults: ``inject_nan`` (attribute: packets carry NaN values with a valid CRC: the parser must
reject them), ``dropout`` (attribute: nothing is sent), ``dropout_prob`` (a packet lost),
``corrupt_fraction`` (a byte flipped in a packet: caught by the CRC). ``noise = False`` turns
bias and noise off (for decoding tests).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from common.messages import GroundTruth, ImuSample, RawBytes
from sensors.imu_protocol import encode_imu_packet
from simulator.config import WorldConfig

GRAVITY_MPS2 = 9.81
_NORMAL_BLOCK = 256


@dataclass(frozen=True, slots=True)
class ImuNoise:
    """IMU settings that the simulator config does not carry."""

    accel_bias_walk: float = 2e-4
    """Accelerometer bias random walk (m/s^2 per sqrt(s))."""
    gyro_bias_walk: float = 2e-5
    """Gyro bias random walk (rad/s per sqrt(s))."""
    startup_offset_s: float = 5.0
    """Sensor time since power-on when the simulation starts (s)."""
    lever_arm: bool = True
    """Include the mounting offset car.imu_x_m (centripetal and tangential terms)."""


class ImuModel:
    """Emits the IMU packets due up to each ``poll`` time; deterministic for a given ``rng``."""

    def __init__(self, config: WorldConfig, rng: np.random.Generator,
                 noise: ImuNoise | None = None) -> None:
        self.cfg = config.sim.imu
        self.settings = noise or ImuNoise()
        self.rng = rng
        self.imu_x_m = config.car.imu_x_m if self.settings.lever_arm else 0.0
        self.enabled = self.cfg.enabled and self.cfg.rate_hz > 0
        self.period_s = 1.0 / self.cfg.rate_hz if self.cfg.rate_hz > 0 else math.inf
        self.noise = True
        """False: no bias and no noise (for decoding tests)."""
        self.inject_nan = False
        """Fault switch (imu-nan): packets carry NaN values."""
        self.dropout = False
        """Fault switch: while True nothing is sent."""
        self.dropout_prob = self.cfg.dropout_prob
        self.corrupt_fraction = self.cfg.corrupt_prob
        self._accel_bias: list[float] = (
            rng.normal(0.0, 1.0, 3) * self.cfg.accel_bias_sigma_mps2).tolist()
        self._gyro_bias: list[float] = (
            rng.normal(0.0, 1.0, 3) * self.cfg.gyro_bias_sigma_radps).tolist()
        self._normals: list[list[float]] = []
        self._normals_i = 0
        self._next_k = 0
        self._prev: tuple[float, float, float, float] | None = None
        self._deriv = (0.0, 0.0, 0.0)

    # -- public ---------------------------------------------------------------------------

    def true_sample(self, t_s: float, truth: GroundTruth, vehicle: Any = None) -> ImuSample:
        """The noise-free reading at ``t_s``: from ``vehicle.accel_at`` when given, else from
        the derivatives of ``truth`` between the latest polls."""
        r, d = truth.yaw_rate_radps, self.imu_x_m
        accel_at = getattr(vehicle, "accel_at", None) if vehicle is not None else None
        if callable(accel_at):
            ax, ay = (float(v) for v in accel_at(d, 0.0))
        else:
            dvx, dvy, dr = self._deriv
            ax = dvx - r * truth.vy_mps - r * r * d
            ay = dvy + r * truth.vx_mps + dr * d
        return ImuSample(
            timestamp_s=t_s,
            accel_x_mps2=ax,
            accel_y_mps2=ay,
            accel_z_mps2=GRAVITY_MPS2,
            gyro_x_radps=0.0,
            gyro_y_radps=0.0,
            gyro_z_radps=r,
        )

    def poll(self, t_s: float, truth: GroundTruth, vehicle: Any = None,
             track: Any = None) -> list[RawBytes]:
        """Every packet due up to ``t_s`` (s), one :class:`RawBytes` each, in time order."""
        self._update_derivatives(truth)
        out: list[RawBytes] = []
        if not self.enabled:
            return out
        while self._next_k * self.period_s <= t_s + 1e-9:
            sample_t = self._next_k * self.period_s
            self._next_k += 1
            sample = self._measure(sample_t, truth, vehicle)
            if self.dropout or (self.dropout_prob > 0 and self.rng.random() < self.dropout_prob):
                continue
            packet = encode_imu_packet(sample, sample_t + self.settings.startup_offset_s)
            if self.corrupt_fraction > 0 and self.rng.random() < self.corrupt_fraction:
                packet = self._corrupt(packet)
            out.append(RawBytes(sample_t, "imu", packet))
        return out

    # -- internals ------------------------------------------------------------------------

    def _update_derivatives(self, truth: GroundTruth) -> None:
        now = (truth.timestamp_s, truth.vx_mps, truth.vy_mps, truth.yaw_rate_radps)
        prev = self._prev
        if prev is not None:
            dt = now[0] - prev[0]
            if dt > 1e-9:
                self._deriv = ((now[1] - prev[1]) / dt, (now[2] - prev[2]) / dt,
                               (now[3] - prev[3]) / dt)
            elif dt < 0:
                self._deriv = (0.0, 0.0, 0.0)
        if prev is None or now[0] != prev[0]:
            self._prev = now

    def _measure(self, t_s: float, truth: GroundTruth, vehicle: Any) -> ImuSample:
        true = self.true_sample(t_s, truth, vehicle)
        if self.inject_nan:
            nan = math.nan
            return ImuSample(t_s, nan, nan, nan, nan, nan, nan)
        if not self.noise:
            return true
        cfg, s = self.cfg, self.settings
        z = self._standard_normals()
        root_dt = math.sqrt(self.period_s)
        walk_a, walk_g = s.accel_bias_walk * root_dt, s.gyro_bias_walk * root_dt
        ab, gb = self._accel_bias, self._gyro_bias
        for i in range(3):
            ab[i] += walk_a * z[i]
            gb[i] += walk_g * z[3 + i]
        sa, sg = cfg.accel_sigma_mps2, cfg.gyro_sigma_radps
        return ImuSample(
            t_s,
            true.accel_x_mps2 + ab[0] + sa * z[6],
            true.accel_y_mps2 + ab[1] + sa * z[7],
            true.accel_z_mps2 + ab[2] + sa * z[8],
            true.gyro_x_radps + gb[0] + sg * z[9],
            true.gyro_y_radps + gb[1] + sg * z[10],
            true.gyro_z_radps + gb[2] + sg * z[11],
        )

    def _standard_normals(self) -> list[float]:
        """Twelve N(0, 1) draws for one sample (drawn from ``rng`` in blocks, for speed)."""
        if self._normals_i >= len(self._normals):
            self._normals = self.rng.standard_normal((_NORMAL_BLOCK, 12)).tolist()
            self._normals_i = 0
        row: list[float] = self._normals[self._normals_i]
        self._normals_i += 1
        return row

    def _corrupt(self, packet: bytes) -> bytes:
        data = bytearray(packet)
        i = int(self.rng.integers(1, len(data)))
        data[i] ^= 1 << int(self.rng.integers(8))
        return bytes(data)
