"""The scripted driver of the exploration lap (on the car a person drives it).

Pure pursuit on the TRUE pose along the track's centreline, at a moderate target speed that
it lowers ahead of bends (lateral acceleration at most ``max_lateral_mps2``), with a little
seeded, smoothed steering noise so that no two runs look machine-perfect. On a track that is
not a loop it brakes to a stop at the end of the centreline.
"""

from __future__ import annotations

import math

import numpy as np

from common.car import CarConfig
from common.messages import ActuatorCommand, AsState, GroundTruth
from common.polyline import polyline_curvature
from simulator.track import Track


class ScriptedDriver:
    """Follows ``track``'s centreline; ``command(truth, t_s)`` gives the next command."""

    def __init__(self, track: Track, car: CarConfig, seed: int = 0, speed_mps: float = 7.0,
                 steer_noise_rad: float = 0.01, max_lateral_mps2: float = 5.0) -> None:
        self.track = track
        self.car = car
        self.speed_mps = speed_mps
        self.steer_noise_rad = steer_noise_rad
        self.max_lateral_mps2 = max_lateral_mps2
        self.rng = np.random.default_rng(seed)
        self._noise = 0.0
        self._last_t: float | None = None
        self._hint: int | None = None
        kappa = np.abs(polyline_curvature(track.centreline_xy_m, track.is_loop))
        # the largest curvature within the next ~12 m at each centreline sample
        step = max(track.lap_length_m / max(len(kappa), 1), 1e-3)
        ahead = max(int(12.0 / step), 1)
        if track.is_loop:
            stacked = np.stack([np.roll(kappa, -k) for k in range(0, ahead)])
        else:
            padded = np.concatenate([kappa, np.full(ahead, kappa[-1])])
            stacked = np.stack([padded[k:k + len(kappa)] for k in range(0, ahead)])
        self._kappa_ahead = stacked.max(axis=0).tolist()
        self._end_s = float(track.centreline_s_m[-1])
        self.progress_m = 0.0

    def target_speed_mps(self, s_m: float, seg: int) -> float:
        """The speed the driver wants at progress ``s_m`` on centreline segment ``seg``."""
        k = self._kappa_ahead[seg]
        v = min(self.speed_mps, math.sqrt(self.max_lateral_mps2 / max(k, 1e-6)))
        if not self.track.is_loop:
            # stop with the front of the car a metre short of the end of the centreline
            remaining = self._end_s - s_m - (self.car.length_m - self.car.rear_overhang_m) - 1.0
            v = min(v, math.sqrt(max(2.0 * 4.0 * remaining, 0.0)))
        return max(v, 0.0)

    def command(self, truth: GroundTruth, t_s: float) -> ActuatorCommand:
        """The throttle/brake/steering for the car at ``truth`` (time ``t_s``)."""
        car = self.car
        yaw = truth.yaw_rad
        s, _, seg = self.track.locate(truth.x_m, truth.y_m, self._hint)
        self._hint = seg
        self.progress_m = s
        v = max(truth.vx_mps, 0.0)
        lookahead = min(max(0.4 * v + 1.5, 2.5), 8.0)
        tx, ty, _ = self.track.point_at(s + lookahead)
        dx, dy = tx - truth.x_m, ty - truth.y_m
        c, si = math.cos(yaw), math.sin(yaw)
        lx = dx * c + dy * si
        ly = -dx * si + dy * c
        ld2 = max(lx * lx + ly * ly, 1e-6)
        steer = math.atan(2.0 * car.wheelbase_m * ly / ld2)
        # Ornstein-Uhlenbeck steering noise with a 0.5 s time constant
        dt = 0.0 if self._last_t is None else max(t_s - self._last_t, 0.0)
        self._last_t = t_s
        if dt > 0.0 and self.steer_noise_rad > 0.0:
            a = math.exp(-dt / 0.5)
            self._noise = a * self._noise + math.sqrt(1.0 - a * a) * self.steer_noise_rad * float(
                self.rng.standard_normal())
        steer = min(max(steer + self._noise, -car.max_steer_rad), car.max_steer_rad)
        target = self.target_speed_mps(s, seg)
        err = target - v
        throttle = brake = 0.0
        if err > 0.0:
            throttle = min(0.4 * err + 0.05, 1.0)
        elif err < -0.3:
            brake = min(-0.25 * err, 1.0)
        if target <= 0.0 and v < 0.3:
            brake, throttle = 1.0, 0.0
        return ActuatorCommand(t_s, throttle, brake, steer, AsState.DRIVING)
