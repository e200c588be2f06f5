"""The GNSS world frame: the start pose found in the ENU frame of the first fix.

The ENU origin is the first fix; the world frame is the start pose, so its heading in ENU is
needed. Either it is known (a dual antenna, a magnetometer or a surveyed start: the mission's
``start_heading_enu_rad``, handed to the Mapper by Main) or it is estimated, by default from
the GNSS course over ground against the filter's own course (gyro-integrated yaw plus slip
angle) once moving above ``gnss_min_speed_mps``, averaged (weights speed squared) over
``heading_estimate_samples`` fixes; without courses (a GGA-only receiver) by aligning the GNSS
track with the filter's over the first ``track_alignment_distance_m`` (2-D Procrustes). The
start position in ENU is then the mean over the collected fixes of ``fix - R(heading) p_filter``.
"""

from __future__ import annotations

import logging
import math

import numpy as np
from numpy.typing import NDArray

from common.conventions import LocalTangentFrame, WorldFrame, wrap_angle

log = logging.getLogger(__name__)

FloatArray = NDArray[np.float64]


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
