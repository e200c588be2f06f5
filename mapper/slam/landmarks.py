"""What the SLAM knows of each landmark besides its position: a stable id, when it was first and
last seen (as travel along the odometer, m) and the votes for its colour and size class.

One row per landmark, in the order of the landmarks in the filter's state. Colour and size
are votes: each associated LiDAR detection votes for its size (and colour, if it has
one), each camera cone for the colour of the nearest landmark (weighted by its confidence).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import linear_sum_assignment

from common.messages import ConeColour, ConeDetection, ConeSize
from mapper.colour_votes import voted_colours
from mapper.slam.models import FloatArray

N_COLOURS = len(ConeColour)
N_SIZES = len(ConeSize)
BIG = 1.0e9
"""The cost of a forbidden pair in an assignment."""


class LandmarkBook:
    """Ids, first and last sighting (odometer, m) and colour / size votes of every landmark."""

    def __init__(self) -> None:
        self.ids = np.zeros(0, np.int64)
        self.first_seen_m = np.zeros(0)
        self.last_seen_m = np.zeros(0)
        self.colour_votes = np.zeros((0, N_COLOURS))
        self.size_votes = np.zeros((0, N_SIZES))
        self.next_id = 0

    def reset(self, count: int, odometer_m: float) -> None:
        """``count`` landmarks with fresh ids, seen now, no votes (a loaded state)."""
        self.ids = np.arange(count, dtype=np.int64)
        self.next_id = count
        self.first_seen_m = np.full(count, odometer_m)
        self.last_seen_m = np.full(count, odometer_m)
        self.colour_votes = np.zeros((count, N_COLOURS))
        self.size_votes = np.zeros((count, N_SIZES))

    def add(self, odometer_m: float, sizes: NDArray[np.int64],
            colours: NDArray[np.int64]) -> None:
        """New landmarks (one per entry of ``sizes`` / ``colours``, their first votes), seen
        now."""
        a = sizes.size
        self.ids = np.concatenate([self.ids, np.arange(self.next_id, self.next_id + a)])
        self.next_id += a
        now = np.full(a, odometer_m)
        self.first_seen_m = np.concatenate([self.first_seen_m, now])
        self.last_seen_m = np.concatenate([self.last_seen_m, now])
        votes_s = np.zeros((a, N_SIZES))
        votes_s[np.arange(a), sizes] = 1.0
        votes_c = np.zeros((a, N_COLOURS))
        votes_c[np.arange(a), colours] = 1.0
        self.size_votes = np.concatenate([self.size_votes, votes_s])
        self.colour_votes = np.concatenate([self.colour_votes, votes_c])

    def keep(self, mask: NDArray[np.bool_]) -> None:
        """Keep the rows of ``mask`` (N,) (landmarks deleted from the filter)."""
        self.ids = self.ids[mask]
        self.first_seen_m = self.first_seen_m[mask]
        self.last_seen_m = self.last_seen_m[mask]
        self.colour_votes = self.colour_votes[mask]
        self.size_votes = self.size_votes[mask]

    def seen(self, lm: NDArray[np.int64], odometer_m: float, sizes: NDArray[np.int64],
             colours: NDArray[np.int64]) -> None:
        """Landmarks ``lm`` seen now by detections of these sizes and colours (their votes)."""
        self.last_seen_m[lm] = odometer_m
        self.size_votes[lm, sizes] += 1.0
        self.colour_votes[lm, colours] += 1.0

    def colours(self) -> NDArray[np.int64]:
        """Each landmark's colour by vote (:func:`mapper.colour_votes.voted_colours`: UNKNOWN
        until a colour leads by a full vote)."""
        return voted_colours(self.colour_votes)

    def sizes(self) -> NDArray[np.int64]:
        """Each landmark's size class by majority (UNKNOWN without a vote for a size)."""
        votes = self.size_votes[:, 1:]
        out = np.argmax(votes, axis=1) + 1
        out[np.max(votes, axis=1) <= 0.0] = int(ConeSize.UNKNOWN)
        return out.astype(np.int64)

    def big_orange(self, min_votes: float) -> NDArray[np.bool_]:
        """Landmarks that are big orange cones: size LARGE or colour BIG_ORANGE by vote, with
        at least ``min_votes`` votes for it."""
        large = (self.sizes() == int(ConeSize.LARGE)) & (
            self.size_votes[:, int(ConeSize.LARGE)] >= min_votes)
        orange = (self.colours() == int(ConeColour.BIG_ORANGE)) & (
            self.colour_votes[:, int(ConeColour.BIG_ORANGE)] >= min_votes)
        return large | orange

    def vote_colours(self, cones: Sequence[ConeDetection], pose: tuple[float, float, float],
                     landmarks_xy_m: FloatArray, gate_m: float) -> int:
        """Camera cones (vehicle frame at ``pose`` = x, y, yaw) vote for the colour of the
        nearest landmark (``landmarks_xy_m`` (N, 2), world frame) within ``gate_m``, one cone
        per landmark (a global assignment), weighted by their confidence. Returns the number
        of votes cast."""
        px, py, yaw = pose
        arr = np.array([(d.x_m, d.y_m, int(d.colour), d.confidence) for d in cones], np.float64)
        arr = arr[np.all(np.isfinite(arr), axis=1)]
        colours = arr[:, 2].astype(np.int64)
        keep = (colours > int(ConeColour.UNKNOWN)) & (colours < N_COLOURS)
        arr, colours = arr[keep], colours[keep]
        if arr.shape[0] == 0:
            return 0
        cy, sy = math.cos(yaw), math.sin(yaw)
        wx = px + cy * arr[:, 0] - sy * arr[:, 1]
        wy = py + sy * arr[:, 0] + cy * arr[:, 1]
        lm = landmarks_xy_m
        d = np.hypot(wx[:, None] - lm[None, :, 0], wy[:, None] - lm[None, :, 1])
        cost = np.where(d <= gate_m, d, BIG)
        rows, cols = linear_sum_assignment(cost)
        good = cost[rows, cols] < BIG
        np.add.at(self.colour_votes, (cols[good], colours[rows[good]]),
                  np.clip(arr[rows[good], 3], 0.0, 1.0))
        return int(np.count_nonzero(good))
