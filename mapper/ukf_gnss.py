"""Seed 001's GNSS measurement models in the UKF: the position and the twist (speed, track).

The world-frame position is that of a frame whose heading may be off by the offset state
(``UkfConfig.gnss_heading_state``): the fix is the true position turned by it about the start.
The twist is fused only above ``gnss_min_speed_mps``: z = (course, speed) with the unscented
transform of h(x) = (yaw + atan2(vy + w a, vx) + offset, |(vx, vy + w a)|), a the antenna's
offset ahead of the rear axle; the track's variance is the seed's ``sigma_v^2 / v^2``
(floored).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from common.messages import GpsFix
from mapper.config import UkfConfig
from mapper.ukf_state import IVX, IVY, IW, IX, IY, IYAW

if TYPE_CHECKING:
    from mapper.ukf_localiser import UkfLocaliser

FloatArray = NDArray[np.float64]


def receiver_covariance(cfg: UkfConfig, fix: GpsFix,
                        frame_yaw_enu_rad: float) -> FloatArray | None:
    """The fix's position covariance (2, 2) in the world frame (turned by
    ``frame_yaw_enu_rad`` from ENU) from the receiver's own 1-sigma latitude and longitude
    errors; None when the fix has none (or ``gnss_sigma_from_receiver`` is off)."""
    lat_s, lon_s = fix.lat_sigma_m, fix.lon_sigma_m
    if not (cfg.gnss_sigma_from_receiver and math.isfinite(lat_s) and math.isfinite(lon_s)
            and lat_s > 0.0 and lon_s > 0.0):
        return None
    k, floor = cfg.gnss_receiver_sigma_scale, cfg.gnss_receiver_sigma_floor_m
    enu = np.diag([(k * max(lon_s, floor)) ** 2, (k * max(lat_s, floor)) ** 2])
    c, s = math.cos(frame_yaw_enu_rad), math.sin(frame_yaw_enu_rad)
    rot = np.array([[c, s], [-s, c]])  # ENU to world
    return np.asarray(rot @ enu @ rot.T, np.float64)


def update_position(ukf: UkfLocaliser, xy_world_m: FloatArray,
                    cov: FloatArray | None = None) -> bool:
    """Seed 001's GNSS pose model: z = (x, y) in the world frame, ``cov`` (2, 2) or the
    configured sigma; the antenna ``gnss_antenna_x_m`` ahead of the rear axle (seed 001 has it
    there: 0)."""
    cfg = ukf.config
    if not cfg.use_gnss_position:
        return False
    z = np.asarray(xy_world_m, np.float64).reshape(2)
    if not np.all(np.isfinite(z)):
        ukf.count("gnss_position", "rejected_invalid")
        return False
    R = np.eye(2) * cfg.gnss_position_sigma_m**2 if cov is None else np.asarray(cov)
    H = np.zeros((2, ukf.n))
    H[0, IX] = 1.0
    H[1, IY] = 1.0
    predicted = ukf.x[:2].copy()
    if ukf.ih is not None:
        # The frame turned by the offset b about the start: h = p + b (-y, x) (small b).
        px, py, b = float(ukf.x[IX]), float(ukf.x[IY]), float(ukf.x[ukf.ih])
        predicted += b * np.array([-py, px])
        H[0, ukf.ih] = -py
        H[1, ukf.ih] = px
        H[0, IY] = -b
        H[1, IX] = b
    a = cfg.gnss_antenna_x_m
    if a != 0.0:
        # The antenna a ahead of the rear axle: h = p + a (cos yaw, sin yaw).
        c, s = math.cos(float(ukf.x[IYAW])), math.sin(float(ukf.x[IYAW]))
        predicted += a * np.array([c, s])
        H[0, IYAW] += -a * s
        H[1, IYAW] += a * c
    return ukf.update_linear("gnss_position", z - predicted, H, R,
                             cfg.gnss_position_gate_sigma)


def update_velocity(ukf: UkfLocaliser, speed_mps: float, course_world_rad: float,
                    speed_sigma_mps: float | None = None) -> bool:
    """Seed 001's GNSS twist model: speed and track (course over ground, world yaw).

    Only above ``gnss_min_speed_mps``; the track's variance is the seed's
    ``sigma_v^2 / v^2`` (floored)."""
    cfg = ukf.config
    if not cfg.use_gnss_velocity:
        return False
    if not (math.isfinite(speed_mps) and math.isfinite(course_world_rad)):
        ukf.count("gnss_velocity", "rejected_invalid")
        return False
    if speed_mps < cfg.gnss_min_speed_mps:
        ukf.count("gnss_velocity", "skipped_slow")
        return False
    sv = cfg.gnss_speed_sigma_mps if speed_sigma_mps is None else speed_sigma_mps
    s_track = max(sv / speed_mps, cfg.gnss_track_sigma_floor_rad)
    a = cfg.gnss_antenna_x_m
    ih = ukf.ih

    def h(chi: FloatArray) -> FloatArray:
        vy = chi[:, IVY] + chi[:, IW] * a
        course = chi[:, IYAW] + np.arctan2(vy, chi[:, IVX])
        if ih is not None:
            course = course + chi[:, ih]
        return np.stack([course, np.hypot(chi[:, IVX], vy)], axis=1)

    z = np.array([course_world_rad, speed_mps])
    R = np.diag([s_track**2, sv**2])
    return ukf.update_unscented("gnss_velocity", z, h, R, (0,),
                                cfg.gnss_velocity_gate_sigma)
