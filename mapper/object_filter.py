"""Object localisation and the object filter (seed 002, section 7.2, in our conventions).

Seed 002 turns a LiDAR object from its car frame (y forward, x right, bearings clockwise from y)
into its world frame with a distance and a bearing. Ours is the same rigid transform written in
the stack's conventions (vehicle x forward, y left, yaw counter-clockwise):
:func:`common.conventions.vehicle_to_world`; ``tests/test_conventions.py`` checks that the two
agree through :func:`common.conventions.seed_car_to_world`.

The filter drops objects that are too near, too far, too small or too big to be a cone: false
positives from dust, marks on the sensor window or scattered light (seed 002, 7.2).
"""

from __future__ import annotations

import logging
import math
from collections import Counter
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from common.conventions import vehicle_to_world
from common.messages import ConeDetection, ConeSize
from mapper.config import ObjectFilterConfig

log = logging.getLogger(__name__)

#: Cone dimensions (width, height) in metres by size class (FS rules: small 228 x 325 mm,
#: large 285 x 505 mm).
CONE_DIMENSIONS_M: dict[int, tuple[float, float]] = {
    int(ConeSize.SMALL): (0.228, 0.325),
    int(ConeSize.LARGE): (0.285, 0.505),
}


def detection_sizes(cones: Sequence[ConeDetection]) -> NDArray[np.float64]:
    """(N, 2) width, height (m) of each detection: measured, else its size class, else NaN."""
    out = np.full((len(cones), 2), np.nan)
    for i, c in enumerate(cones):
        w, h = c.width_m, c.height_m
        if (math.isnan(w) or math.isnan(h)) and int(c.size) in CONE_DIMENSIONS_M:
            dw, dh = CONE_DIMENSIONS_M[int(c.size)]
            w = dw if math.isnan(w) else w
            h = dh if math.isnan(h) else h
        out[i] = (w, h)
    return out


def localise_objects(
    cones: Sequence[ConeDetection], pose_x_m: float, pose_y_m: float, pose_yaw_rad: float
) -> NDArray[np.float64]:
    """Vehicle-frame detections to world positions (N, 2) (m) for a car at the given pose."""
    if not cones:
        return np.zeros((0, 2))
    xy = np.array([(c.x_m, c.y_m) for c in cones], dtype=np.float64)
    return vehicle_to_world(xy, pose_x_m, pose_y_m, pose_yaw_rad).reshape(-1, 2)


class ObjectFilter:
    """Rejects detections by range and by size; ``rejects`` counts the reasons."""

    def __init__(self, config: ObjectFilterConfig) -> None:
        self.config = config
        self.rejects: Counter[str] = Counter()
        self.accepted = 0

    def keep(self, cone: ConeDetection) -> bool:
        """True when ``cone`` may be a cone; unknown sizes (NaN) pass the size tests."""
        cfg = self.config
        if not (math.isfinite(cone.x_m) and math.isfinite(cone.y_m)):
            self.rejects["not_finite"] += 1
            return False
        r = math.hypot(cone.x_m, cone.y_m)
        if r < cfg.min_range_m:
            self.rejects["too_near"] += 1
            return False
        if r > cfg.max_range_m:
            self.rejects["too_far"] += 1
            return False
        h, w = cone.height_m, cone.width_m
        if not math.isnan(h) and not cfg.min_height_m <= h <= cfg.max_height_m:
            self.rejects["bad_height"] += 1
            return False
        if not math.isnan(w) and not cfg.min_width_m <= w <= cfg.max_width_m:
            self.rejects["bad_width"] += 1
            return False
        self.accepted += 1
        return True

    def filter(self, cones: Sequence[ConeDetection]) -> list[ConeDetection]:
        """The detections that pass, in their order."""
        return [c for c in cones if self.keep(c)]
