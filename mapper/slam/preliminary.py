"""The preliminary landmark list (seed 000, 5.3.3).

A detection that no landmark explains does not enter the filter at once: it waits in the
preliminary list (world frame) and becomes a landmark only when a detection of the next sweep
falls within ``preliminary_gate_m`` of it. A single false detection (a reflection, a person's
leg) is thus never mapped; a real cone seen in two consecutive sweeps is.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import linear_sum_assignment

from mapper.slam.landmarks import BIG
from mapper.slam.models import FloatArray


class PreliminaryList:
    """The previous sweep's unexplained detections: world positions (K, 2), sizes, colours."""

    def __init__(self, gate_m: float) -> None:
        self.gate_m = gate_m
        self.xy = np.zeros((0, 2))
        self.sizes = np.zeros(0, np.int64)
        self.colours = np.zeros(0, np.int64)

    def clear(self) -> None:
        """An empty sweep: nothing carries over."""
        self.xy = np.zeros((0, 2))
        self.sizes = np.zeros(0, np.int64)
        self.colours = np.zeros(0, np.int64)

    def promote(self, world_xy_m: FloatArray, sizes: NDArray[np.int64],
                colours: NDArray[np.int64]) -> NDArray[np.bool_]:
        """This sweep's unexplained detections (world (a, 2), their size and colour classes):
        returns the mask (a,) of those seen again (one per candidate, a global assignment),
        whose unknown size and colour take the candidate's (in place); the rest become the
        new list."""
        promote = np.zeros(world_xy_m.shape[0], bool)
        if self.xy.shape[0] and world_xy_m.shape[0]:
            d = np.hypot(world_xy_m[:, None, 0] - self.xy[None, :, 0],
                         world_xy_m[:, None, 1] - self.xy[None, :, 1])
            cost = np.where(d <= self.gate_m, d, BIG)
            rows, cols = linear_sum_assignment(cost)
            good = cost[rows, cols] < BIG
            ri, ci = rows[good], cols[good]
            promote[ri] = True
            sizes[ri] = np.where(sizes[ri] == 0, self.sizes[ci], sizes[ri])
            colours[ri] = np.where(colours[ri] == 0, self.colours[ci], colours[ri])
        self.xy = world_xy_m[~promote]
        self.sizes = sizes[~promote]
        self.colours = colours[~promote]
        return promote
