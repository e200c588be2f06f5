"""Fusion plumbing: the delay buffer, prediction to now, motion compensation, the GNSS frame.

Seed 000, 6.2.1 (first method): LiDAR (about 10 ms) and camera (about 100 ms) detections arrive
late and out of order with the IMU, odometry and GNSS. Every reading goes into a
:class:`DelayBuffer`; the filter is kept *lagged* at the latest time every live source has
reported (the horizon), and the buffered readings up to the horizon are applied in the order they
were made. The pose handed to control is the lagged state predicted forward to now with the
buffered IMU samples (:func:`predict_forward`, the mean only: cheap, and the gap is short).

The GNSS world frame (:class:`GnssFrameEstimator`): the ENU origin is the first fix; the world
frame is the start pose, so its heading in ENU is needed. Either it is known (a dual antenna, a
magnetometer or a surveyed start: the mission's ``start_heading_enu_rad``, handed to the
Mapper by Main) or it is estimated, by default from the GNSS course over
ground against the filter's own course (gyro-integrated yaw plus slip angle) once moving above
``gnss_min_speed_mps``, averaged (weights speed squared) over ``heading_estimate_samples`` fixes;
without courses (a GGA-only receiver) by aligning the GNSS track with the filter's over the first
``track_alignment_distance_m`` (2-D Procrustes). The start position in ENU is then the mean over
the collected fixes of ``fix - R(heading) p_filter``. The first fix of a source never heard
before may find the lagged filter already past its time: it is counted as late and dropped.
"""

from __future__ import annotations

import heapq
import itertools
import logging
import math
from collections import Counter
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from common.conventions import LocalTangentFrame, WorldFrame, wrap_angle
from common.messages import ConeDetection, ImuSample, Reading

log = logging.getLogger(__name__)

FloatArray = NDArray[np.float64]


class DelayBuffer:
    """Readings from several streams, released in timestamp order up to the common horizon.

    ``push(stream, reading, now_s)``; ``pop_ready(now_s)`` returns the readings whose timestamp is
    at most :meth:`horizon`: the smallest latest-timestamp over the streams heard from within
    ``max_delay_s`` of ``now_s``, never older than ``now_s - max_delay_s`` (a dead source does
    not stall the filter). A reading older than what was already released is counted in
    ``late`` and dropped (it cannot be applied in order).
    """

    def __init__(self, max_delay_s: float) -> None:
        self.max_delay_s = max_delay_s
        self._heap: list[tuple[float, int, str, Reading]] = []
        self._seq = itertools.count()
        self.latest_s: dict[str, float] = {}
        self.heard_s: dict[str, float] = {}
        self.released_s = -math.inf
        self.late: Counter[str] = Counter()

    def __len__(self) -> int:
        return len(self._heap)

    def push(self, stream: str, reading: Reading, now_s: float) -> bool:
        """Buffer ``reading``; False (counted) when it is older than the released horizon."""
        t = reading.timestamp_s
        if t > self.latest_s.get(stream, -math.inf):
            self.latest_s[stream] = t
        self.heard_s[stream] = now_s
        if t < self.released_s:
            self.late[stream] += 1
            return False
        heapq.heappush(self._heap, (t, next(self._seq), stream, reading))
        return True

    def horizon(self, now_s: float) -> float:
        """The time up to which every live stream has reported (s)."""
        live = [self.latest_s[s] for s, heard in self.heard_s.items()
                if now_s - heard <= self.max_delay_s]
        h = min(live) if live else now_s
        return max(h, now_s - self.max_delay_s)

    def pop_ready(self, now_s: float) -> list[tuple[str, Reading]]:
        """The buffered readings up to the horizon, in timestamp order (ties: arrival order)."""
        h = self.horizon(now_s)
        out: list[tuple[str, Reading]] = []
        heap = self._heap
        while heap and heap[0][0] <= h:
            _t, _n, stream, reading = heapq.heappop(heap)
            out.append((stream, reading))
        if out:
            self.released_s = max(self.released_s, out[-1][1].timestamp_s)
        return out


def predict_forward(state: FloatArray, t_from_s: float, samples: Sequence[ImuSample],
                    gyro_bias_radps: float, accel_bias_mps2: FloatArray,
                    imu_x_m: float = 0.0) -> tuple[FloatArray, float]:
    """Dead-reckon the mean state (x, y, yaw, vx, vy, yaw rate) (6,) from ``t_from_s`` through
    the IMU ``samples`` newer than it; returns (state (6,), time reached)."""
    x, y, yaw, vx, vy, w = (float(v) for v in state[:6])
    t = t_from_s
    bx = float(accel_bias_mps2[0])
    for s in samples:
        dt = s.timestamp_s - t
        if dt <= 0.0:
            continue
        dt = min(dt, 0.05)
        c, sn = math.cos(yaw), math.sin(yaw)
        x += (vx * c - vy * sn) * dt
        y += (vx * sn + vy * c) * dt
        w_old = w
        w = s.gyro_z_radps - gyro_bias_radps
        yaw += 0.5 * (w_old + w) * dt  # the interval's mean yaw rate, as the filters
        vx += (s.accel_x_mps2 - bx + w * w * imu_x_m + w * vy) * dt
        t = s.timestamp_s
    return np.array([x, y, wrap_angle(yaw), vx, vy, w]), t


def rear_slip_velocity(vx_mps: float, yaw_rate_radps: float, slip_rad_per_mps2: float,
                       max_lateral_accel_mps2: float = math.inf) -> tuple[float, float, float]:
    """Lateral velocity (m/s) of the rear axle in a corner, and its derivatives with respect to
    vx and the yaw rate: ``(vy, d vy / d vx, d vy / d w)``.

    The rear tyres carry their share of the lateral force at a slip angle: for a tyre law
    ``F / Fz = mu tanh(C alpha / mu)`` (C cornering stiffness per load, 1/rad) in a steady
    corner ``F / Fz = a_y / g`` with ``a_y = vx w``, so ``alpha = k a_max atanh(a_y / a_max)``,
    ``k = 1 / (C g)`` (``slip_rad_per_mps2``), ``a_max = mu g`` (the car's lateral limit);
    linear ``alpha = k a_y`` for an infinite ``a_max``. The axle slides outwards at
    ``vy = -vx alpha``.
    """
    k = slip_rad_per_mps2
    if k == 0.0:
        return 0.0, 0.0, 0.0
    ay = vx_mps * yaw_rate_radps
    if math.isfinite(max_lateral_accel_mps2) and max_lateral_accel_mps2 > 0.0:
        a_max = max_lateral_accel_mps2
        u = min(max(ay / a_max, -0.95), 0.95)
        alpha = k * a_max * math.atanh(u)
        gain = k / (1.0 - u * u) if abs(ay / a_max) < 0.95 else 0.0   # d alpha / d a_y
    else:
        alpha = k * ay
        gain = k
    vy = -vx_mps * alpha
    d_vx = -alpha - vx_mps * gain * yaw_rate_radps
    d_w = -vx_mps * gain * vx_mps
    return vy, d_vx, d_w


def compensate_motion(cones: Sequence[ConeDetection], t_ref_s: float, vx_mps: float,
                      vy_mps: float, yaw_rate_radps: float) -> FloatArray:
    """Vehicle-frame detections (N, 2) moved to the vehicle frame at ``t_ref_s``.

    A detection seen at ``t`` is a fixed world point; the car moves by (vx, vy, w) over
    ``t_ref_s - t``. Detections already stamped ``t_ref_s`` are unchanged."""
    out = np.empty((len(cones), 2))
    for i, c in enumerate(cones):
        dt = t_ref_s - c.timestamp_s
        if not math.isfinite(dt) or abs(dt) < 1e-4:
            out[i] = (c.x_m, c.y_m)
            continue
        th = yaw_rate_radps * dt
        px, py = c.x_m - vx_mps * dt, c.y_m - vy_mps * dt
        ct, st = math.cos(th), math.sin(th)
        out[i] = (ct * px + st * py, -st * px + ct * py)
    return out


class GnssFrameEstimator:
    """Finds the world frame (the start pose) in the ENU frame of the first fix.

    Feed :meth:`add` every fix (ENU east/north, speed, ENU course, the filter's state at the
    fix's time) until :attr:`frame` is set. Each course above ``min_speed_mps`` while the filter
    turns slower than ``max_yaw_rate_radps`` (the slip angle, modelled from the velocity
    states, is small there) gives one heading sample ``course - yaw - atan2(vy, vx)``; the frame
    heading is their circular mean, weights speed squared. After the frame is found :meth:`add`
    goes on collecting samples (a whole exploration lap against the SLAM's yaw gives a heading
    several times better than the first ``heading_samples``): :meth:`heading_estimate` is the
    mean over all of them with its sigma.
    """

    def __init__(self, enu: LocalTangentFrame, known_heading_enu_rad: float | None,
                 heading_samples: int, min_speed_mps: float, alignment_distance_m: float,
                 min_fixes: int = 10, max_yaw_rate_radps: float = math.inf,
                 yaw_error_correlation_s: float = math.inf,
                 alignment_heading_sigma_rad: float = 0.05) -> None:
        self.enu = enu
        self.known_heading = known_heading_enu_rad
        self.heading_samples = max(1, heading_samples)
        self.min_speed_mps = min_speed_mps
        self.alignment_distance_m = alignment_distance_m
        self.min_fixes = min_fixes
        self.max_yaw_rate_radps = max_yaw_rate_radps
        self.yaw_error_correlation_s = yaw_error_correlation_s
        self.alignment_heading_sigma_rad = alignment_heading_sigma_rad
        self._en: list[tuple[float, float]] = []
        self._p: list[tuple[float, float]] = []
        self._samples: list[tuple[float, float, float, float]] = []
        """Heading samples: (time (s), course - filter course (rad), weight, the filter's yaw
        variance (rad^2))."""
        self._travel_m = 0.0
        self.frame: WorldFrame | None = None
        self.frame_sigma_rad = 0.0
        """Sigma of :attr:`frame`'s heading (rad) when it was found; 0 when known."""
        self.method = ""

    def add(self, east_m: float, north_m: float, speed_mps: float, course_enu_rad: float,
            state: FloatArray, yaw_variance_rad2: float = 0.0,
            yaw_rate_radps: float = 0.0, t_s: float = 0.0) -> WorldFrame | None:
        """One fix at ``t_s`` with the filter's state (x, y, yaw, vx, vy) at that time, its yaw
        variance and yaw rate; returns the frame once found."""
        px, py, yaw, vx, vy = (float(v) for v in state[:5])
        if (math.isfinite(course_enu_rad) and math.isfinite(speed_mps)
                and speed_mps >= self.min_speed_mps and vx > 0.5 * self.min_speed_mps
                and abs(yaw_rate_radps) <= self.max_yaw_rate_radps):
            # Weighted by speed^2: the course's noise falls as 1 / speed.
            h = wrap_angle(course_enu_rad - yaw - math.atan2(vy, vx))
            self._samples.append((t_s, h, speed_mps * speed_mps, yaw_variance_rad2))
        if self.frame is not None:
            return self.frame
        if self._p:
            self._travel_m += math.hypot(px - self._p[-1][0], py - self._p[-1][1])
        self._en.append((east_m, north_m))
        self._p.append((px, py))
        heading: float | None = None
        sigma = 0.0
        if self.known_heading is not None:
            if len(self._en) >= self.min_fixes:
                heading, self.method = self.known_heading, "known"
        elif len(self._samples) >= self.heading_samples:
            heading, sigma = self._mean_heading()
            self.method = "course"
        elif self._travel_m >= self.alignment_distance_m and not self._samples:
            heading = self._procrustes_heading()
            sigma = self.alignment_heading_sigma_rad
            self.method = "track_alignment"
        if heading is None:
            return None
        en = np.asarray(self._en)
        p = np.asarray(self._p)
        c, s = math.cos(heading), math.sin(heading)
        rotated = np.stack([c * p[:, 0] - s * p[:, 1], s * p[:, 0] + c * p[:, 1]], axis=1)
        start = (en - rotated).mean(axis=0)
        self.frame = WorldFrame(self.enu, float(start[0]), float(start[1]), wrap_angle(heading))
        self.frame_sigma_rad = sigma
        log.info("GNSS world frame from %d fixes (%s): start at E %.2f N %.2f m, heading %.4f "
                 "rad (sigma %.4f)", len(self._en), self.method, start[0], start[1], heading,
                 sigma)
        return self.frame

    def heading_estimate(self) -> tuple[float, float] | None:
        """The frame heading (rad, ENU) from every heading sample so far and its sigma (rad);
        None when the heading is known or there are too few samples."""
        if self.known_heading is not None or len(self._samples) < self.heading_samples:
            return None
        return self._mean_heading()

    def _mean_heading(self) -> tuple[float, float]:
        """Weighted circular mean of the heading samples and its sigma: the white part from the
        samples' own scatter (sandwich form), plus the filter's yaw error, which is slow: its
        mean variance, divided by the number of ``yaw_error_correlation_s`` spans the samples
        cover (1 for a short span)."""
        t, h, w, yaw_var = (np.asarray(c, np.float64) for c in zip(*self._samples, strict=True))
        mean = math.atan2(float(w @ np.sin(h)), float(w @ np.cos(h)))
        r = np.mod(h - mean + math.pi, 2.0 * math.pi) - math.pi
        w_sum = float(w.sum())
        white = float((w * w) @ (r * r)) / (w_sum * w_sum)
        spans = max(1.0, float(t[-1] - t[0]) / self.yaw_error_correlation_s)
        slow = float(w @ yaw_var) / w_sum / spans
        return mean, math.sqrt(white + slow)

    def _procrustes_heading(self) -> float:
        """Rotation (rad) that best maps the filter's track onto the GNSS track (2-D)."""
        en = np.asarray(self._en)
        p = np.asarray(self._p)
        a = p - p.mean(axis=0)
        b = en - en.mean(axis=0)
        num = float(np.sum(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]))
        den = float(np.sum(a[:, 0] * b[:, 0] + a[:, 1] * b[:, 1]))
        return math.atan2(num, den)
