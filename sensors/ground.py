"""The ground under a LiDAR, estimated from the sweep itself.

Real ground slopes, crowns and dips, and the sensor's height above it is never known to the
centimetre. The lowest return in each cell of a horizontal grid samples the ground (a cone or a
leg fills a cell only partly, so its lowest return is still the ground around it); a quadratic
surface ``z = c0 + c1 x + c2 y + c3 x^2 + c4 y^2 + c5 x y`` is fitted to those samples by least
squares, and refitted twice without the cells whose sample is far from the surface (cells filled
by an object, or by a return from below the ground). A quadratic is enough over the 15-20 m a
cone detector looks at: it follows a slope, a crown and a camber; a bumpier ground leaves
residuals that the detector's height thresholds absorb.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

_FIRST_PASS_RESIDUAL_M = 0.15
"""The first fit takes every cell; cells this far off it are surely not ground (m)."""
_MIN_CELLS = 6
"""Fewer ground cells than unknowns (and a margin) give no surface."""


@dataclass(frozen=True, slots=True)
class GroundSurface:
    """A fitted ground ``z(x, y)`` in the sensor frame (m)."""

    coefficients: NDArray[np.float64]
    """(6,): c0 .. c5 of the module docstring's quadratic."""
    cells_used: int

    def height_m(self, x: NDArray[np.float64], y: NDArray[np.float64]) -> NDArray[np.float64]:
        """The ground's z under each (x, y) (m), same shape as ``x``."""
        c = self.coefficients
        return c[0] + x * (c[1] + c[3] * x + c[5] * y) + y * (c[2] + c[4] * y)

    @property
    def below_sensor_m(self) -> float:
        """The ground's depth below the sensor's origin (m): the mount height."""
        return float(-self.coefficients[0])


def flat_ground(height_below_sensor_m: float) -> GroundSurface:
    """A level ground ``height_below_sensor_m`` below the sensor."""
    coefficients = np.zeros(6)
    coefficients[0] = -height_below_sensor_m
    return GroundSurface(coefficients, 0)


def fit_ground(x: NDArray[np.float64], y: NDArray[np.float64], z: NDArray[np.float64],
               cell_m: float, max_residual_m: float,
               fallback_below_sensor_m: float) -> GroundSurface:
    """Fit the ground to returns ``x, y, z`` (N,) in the sensor frame (m).

    ``cell_m`` is the grid's cell size, ``max_residual_m`` how far a cell's lowest return may
    lie from the surface and still count as ground. With too few cells (an empty or blinded
    sweep) the ground is level at ``fallback_below_sensor_m`` below the sensor.
    """
    if x.size == 0:
        return flat_ground(fallback_below_sensor_m)
    ix = np.floor(x * (1.0 / cell_m)).astype(np.int64)
    iy = np.floor(y * (1.0 / cell_m)).astype(np.int64)
    ix -= ix.min()
    iy -= iy.min()
    key = ix * (int(iy.max()) + 1) + iy
    # each cell's lowest return (the first of a tie), and where it is
    floor = np.full(int(key.max()) + 1, np.inf)
    np.minimum.at(floor, key, z)
    lowest = np.flatnonzero(z == floor[key])
    lowest = lowest[np.unique(key[lowest], return_index=True)[1]]
    if lowest.size < _MIN_CELLS:
        return flat_ground(fallback_below_sensor_m)
    gx, gy, gz = x[lowest], y[lowest], z[lowest]
    design = np.stack([np.ones_like(gx), gx, gy, gx * gx, gy * gy, gx * gy], axis=1)
    use = np.ones(gx.size, dtype=bool)
    coefficients = np.zeros(6)
    for limit in (_FIRST_PASS_RESIDUAL_M, max_residual_m, max_residual_m):
        if use.sum() < _MIN_CELLS:
            return flat_ground(fallback_below_sensor_m)
        coefficients = np.asarray(np.linalg.lstsq(design[use], gz[use], rcond=None)[0],
                                  dtype=np.float64)
        use = np.abs(gz - design @ coefficients) < limit
    return GroundSurface(coefficients, int(use.sum()))
