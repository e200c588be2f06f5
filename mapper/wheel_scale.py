"""The wheels' speed scale learnt from the GNSS receiver's speed.

Wheel speeds come from a nominal tyre radius; the rolling radius differs by a percent or so
(pressure, wear, load), a systematic speed error that dead reckoning integrates (1 % of 170 m
in a GNSS outage is 1.7 m). The receiver's Doppler speed has no such scale: the ratio of its sum
of speeds to the rear wheels' over the same instants (both above ``min_speed_mps``) is the
scale, once ``min_samples`` pairs were summed. Pairs are taken only while the car hardly
accelerates (the wheels' speed changing by less than ``max_accel_mps2`` since the last pair):
the two speeds are not measured at quite the same instant (the receiver's Doppler speed is
filtered), and a lag at 1 m/s^2 biases the ratio by a percent. While GNSS is out the scale
keeps its last value.
"""

from __future__ import annotations

import math


class WheelScaleEstimator:
    """Running ratio GNSS speed / wheel speed (see the module docstring)."""

    def __init__(self, initial_scale: float, min_speed_mps: float = 3.0,
                 min_samples: int = 10, max_accel_mps2: float = 0.3) -> None:
        self.scale = initial_scale
        """The current scale (the initial one until ``min_samples`` pairs)."""
        self.min_speed_mps = min_speed_mps
        self.min_samples = min_samples
        self.max_accel_mps2 = max_accel_mps2
        self._last: tuple[float, float] | None = None  # (time s, wheel speed m/s)
        self.samples = 0
        self._gnss_sum = 0.0
        self._wheel_sum = 0.0

    def add(self, t_s: float, gnss_speed_mps: float, wheel_speed_mps: float) -> float:
        """One pair of speeds at the same instant ``t_s`` (s, m/s); returns the scale."""
        last, self._last = self._last, (t_s, wheel_speed_mps)
        steady = (last is not None and t_s > last[0]
                  and abs(wheel_speed_mps - last[1]) <= self.max_accel_mps2 * (t_s - last[0]))
        if (steady and math.isfinite(gnss_speed_mps) and math.isfinite(wheel_speed_mps)
                and gnss_speed_mps >= self.min_speed_mps
                and wheel_speed_mps >= self.min_speed_mps):
            self._gnss_sum += gnss_speed_mps
            self._wheel_sum += wheel_speed_mps
            self.samples += 1
            if self.samples >= self.min_samples:
                self.scale = self._gnss_sum / self._wheel_sum
        return self.scale
