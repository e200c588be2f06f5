"""World (m, x right/east-ish, y up) to pixel (px, x right, y down) transforms."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike


@dataclass(frozen=True, slots=True)
class WorldToPixel:
    """A uniform scale with the world y axis pointing up the image.

    ``centre_x_m``, ``centre_y_m`` lands on the image centre; ``px_per_m`` pixels per metre.
    """

    width_px: int
    height_px: int
    centre_x_m: float
    centre_y_m: float
    px_per_m: float

    @classmethod
    def fit(cls, width_px: int, height_px: int, points_xy_m: ArrayLike,
            margin_frac: float = 0.06) -> WorldToPixel:
        """The transform that shows every point (N, 2) with a margin (whole-track view)."""
        pts = np.asarray(points_xy_m, dtype=float).reshape(-1, 2)
        pts = pts[np.all(np.isfinite(pts), axis=1)]
        if pts.size == 0:
            return cls(width_px, height_px, 0.0, 0.0, min(width_px, height_px) / 40.0)
        lo, hi = pts.min(axis=0), pts.max(axis=0)
        span = np.maximum(hi - lo, 1.0)
        usable = np.array([width_px, height_px]) * (1.0 - 2.0 * margin_frac)
        scale = float(np.min(usable / span))
        centre = 0.5 * (lo + hi)
        return cls(width_px, height_px, float(centre[0]), float(centre[1]), scale)

    @classmethod
    def follow(cls, width_px: int, height_px: int, x_m: float, y_m: float,
               span_m: float) -> WorldToPixel:
        """A window ``span_m`` wide centred on (x_m, y_m) (follow-the-car view)."""
        return cls(width_px, height_px, x_m, y_m, width_px / max(span_m, 1e-3))

    def to_px(self, points_xy_m: ArrayLike) -> np.ndarray:
        """World points (..., 2) to pixel coordinates (..., 2), float."""
        p = np.asarray(points_xy_m, dtype=float)
        u = (p[..., 0] - self.centre_x_m) * self.px_per_m + 0.5 * self.width_px
        v = 0.5 * self.height_px - (p[..., 1] - self.centre_y_m) * self.px_per_m
        return np.stack([u, v], axis=-1)

    def to_world(self, pixels: ArrayLike) -> np.ndarray:
        """Pixel coordinates (..., 2) back to world points (..., 2)."""
        q = np.asarray(pixels, dtype=float)
        x = (q[..., 0] - 0.5 * self.width_px) / self.px_per_m + self.centre_x_m
        y = (0.5 * self.height_px - q[..., 1]) / self.px_per_m + self.centre_y_m
        return np.stack([x, y], axis=-1)
