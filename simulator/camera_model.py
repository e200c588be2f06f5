"""Simulated camera cone detector: the protobuf datagrams the camera network sends.

The camera sits ``car.camera_x_m`` ahead of the vehicle origin looking forward. At
``config.sim.camera.rate_hz`` it takes an image and reports the cones within ``max_range_m``
and the horizontal field of view ``fov_rad`` (seen from the camera), each in the vehicle frame
at the image time with its colour from the track and a confidence, and with:

- position noise, Gaussian per axis with sigma ``position_sigma_m + range_sigma_per_m * range``;
- misses with probability ``miss_prob`` (growing to twice that at the range limit), and cones
  hidden behind a nearer cone on the same line of sight (not reported);
- colour errors with probability ``colour_error_prob`` (blue and yellow swapped, orange becomes
  unknown);
- false positives: on average ``false_positive_rate`` per image, anywhere in the field of view,
  low confidence, random colour.

The datagram (:func:`sensors.camera_codec.encode_camera_cones`) carries the image time; it
arrives ``latency_s`` later, which is the :class:`RawBytes` timestamp. ``dead = True`` stops
all datagrams (a dead camera).
"""

from __future__ import annotations

import math
from collections import deque
from typing import Any

import numpy as np

from common.messages import CameraCones, ConeColour, ConeDetection, GroundTruth, RawBytes
from sensors.camera_codec import encode_camera_cones
from simulator.config import WorldConfig

CONE_RADIUS_M = 0.13
"""Half-width used for occlusion between cones (m)."""


class CameraModel:
    """Emits the camera datagrams due up to each ``poll`` time; deterministic for a seed."""

    def __init__(self, config: WorldConfig, rng: np.random.Generator) -> None:
        self.cfg = config.sim.camera
        self.rng = rng
        self.camera_x_m = config.car.camera_x_m
        self.enabled = self.cfg.enabled and self.cfg.rate_hz > 0
        self.period_s = 1.0 / self.cfg.rate_hz if self.cfg.rate_hz > 0 else math.inf
        self.noise = True
        """False: no position noise, misses, colour errors or false positives."""
        self.dead = False
        """Fault switch: while True nothing is sent."""
        self._next_frame = 1
        self._queue: deque[tuple[float, bytes]] = deque()

    def poll(self, t_s: float, truth: GroundTruth, vehicle: Any = None,
             track: Any = None) -> list[RawBytes]:
        """Every datagram arriving by ``t_s`` (s), in time order."""
        if not self.enabled:
            return []
        while self._next_frame * self.period_s <= t_s + 1e-9:
            t_img = self._next_frame * self.period_s
            frame = self.frame(t_img, self._next_frame, truth, track)
            self._next_frame += 1
            if not self.dead:
                self._queue.append((t_img + self.cfg.latency_s, encode_camera_cones(frame)))
        out: list[RawBytes] = []
        while self._queue and self._queue[0][0] <= t_s + 1e-9:
            arrival, payload = self._queue.popleft()
            if not self.dead:
                out.append(RawBytes(arrival, "camera", payload))
        return out

    def frame(self, t_img_s: float, frame_id: int, truth: GroundTruth, track: Any
              ) -> CameraCones:
        """The detections of an image taken at ``t_img_s`` (the car's pose extrapolated from
        ``truth`` to that time)."""
        cfg = self.cfg
        dt = t_img_s - truth.timestamp_s
        yaw = truth.yaw_rad + truth.yaw_rate_radps * dt
        c0, s0 = math.cos(truth.yaw_rad), math.sin(truth.yaw_rad)
        x = truth.x_m + (truth.vx_mps * c0 - truth.vy_mps * s0) * dt
        y = truth.y_m + (truth.vx_mps * s0 + truth.vy_mps * c0) * dt
        cones: list[ConeDetection] = []
        if track is not None and len(track.cones_xy_m):
            xy = np.asarray(track.cones_xy_m, dtype=np.float64)
            c, s = math.cos(yaw), math.sin(yaw)
            dx, dy = xy[:, 0] - x, xy[:, 1] - y
            vx = dx * c + dy * s
            vy = -dx * s + dy * c
            cam_x = vx - self.camera_x_m
            rng = np.hypot(cam_x, vy)
            bearing = np.arctan2(vy, cam_x)
            inside = (rng < cfg.max_range_m) & (np.abs(bearing) < 0.5 * cfg.fov_rad) & (rng > 0.5)
            idx = np.flatnonzero(inside)
            idx = idx[np.argsort(rng[idx])]
            colours = np.asarray(track.colours)
            taken: list[tuple[float, float]] = []  # (bearing, half-width) of nearer cones
            for i in idx:
                half = math.atan2(CONE_RADIUS_M, float(rng[i]))
                b = float(bearing[i])
                if any(abs(b - ob) < 0.6 * (half + oh) for ob, oh in taken):
                    continue  # hidden behind a nearer cone
                taken.append((b, half))
                det = self._detect(t_img_s, float(vx[i]), float(vy[i]), float(rng[i]),
                                   ConeColour(int(colours[i])))
                if det is not None:
                    cones.append(det)
        if self.noise and cfg.false_positive_rate > 0:
            for _ in range(int(self.rng.poisson(cfg.false_positive_rate))):
                r = float(self.rng.uniform(1.0, cfg.max_range_m))
                b = float(self.rng.uniform(-0.5, 0.5) * cfg.fov_rad)
                cones.append(ConeDetection(
                    timestamp_s=t_img_s,
                    x_m=self.camera_x_m + r * math.cos(b),
                    y_m=r * math.sin(b),
                    colour=ConeColour(int(self.rng.integers(1, 4))),
                    confidence=float(self.rng.uniform(0.2, 0.6))))
        return CameraCones(timestamp_s=t_img_s, cones=tuple(cones), frame_id=frame_id)

    def _detect(self, t_s: float, x_m: float, y_m: float, range_m: float,
                colour: ConeColour) -> ConeDetection | None:
        cfg = self.cfg
        confidence = max(0.3, 1.0 - 0.5 * range_m / cfg.max_range_m)
        if not self.noise:
            return ConeDetection(t_s, x_m, y_m, colour, confidence=confidence)
        miss = cfg.miss_prob * (1.0 + range_m / cfg.max_range_m)
        if self.rng.random() < miss:
            return None
        sigma = cfg.position_sigma_m + cfg.range_sigma_per_m * range_m
        nx, ny = self.rng.normal(0.0, sigma, 2)
        if self.rng.random() < cfg.colour_error_prob:
            colour = {ConeColour.BLUE: ConeColour.YELLOW,
                      ConeColour.YELLOW: ConeColour.BLUE}.get(colour, ConeColour.UNKNOWN)
        confidence = float(np.clip(confidence + self.rng.normal(0.0, 0.05), 0.05, 1.0))
        return ConeDetection(t_s, x_m + float(nx), y_m + float(ny), colour,
                             confidence=confidence)
