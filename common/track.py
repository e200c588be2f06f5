"""The track: a cone layout and its centreline in the world frame (simulation ground truth).

One type for everyone who handles a track: the simulator builds them (its
:class:`simulator.track.Track` adds the geometric queries the simulated world needs), the
recorder writes one on ``/truth/track``, the player gives it back and the visualiser draws it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from common.messages import FloatArray, IntArray, frozen_array


@dataclass(frozen=True, slots=True, eq=False)
class TrackLayout:
    """A cone layout in the world frame (the car starts at (0, 0) facing +x).

    ``cones_xy_m`` (N, 2); ``colours`` (N,) :class:`~common.messages.ConeColour` values;
    ``sizes`` (N,) :class:`~common.messages.ConeSize` values; ``centreline_xy_m`` (M, 2), for a
    loop the last sample connects back to the first (it is not repeated); ``left_xy_m`` /
    ``right_xy_m`` (L, 2) / (R, 2) the boundary cones ordered along the centreline;
    ``width_m`` the median track width, ``lap_length_m`` the centreline's length (m). Arrays
    are made read-only on construction.
    """

    name: str
    cones_xy_m: FloatArray
    colours: IntArray
    sizes: IntArray
    centreline_xy_m: FloatArray
    left_xy_m: FloatArray
    right_xy_m: FloatArray
    width_m: float
    is_loop: bool
    lap_length_m: float

    def __post_init__(self) -> None:
        for name in ("cones_xy_m", "centreline_xy_m", "left_xy_m", "right_xy_m"):
            object.__setattr__(self, name, frozen_array(getattr(self, name)).reshape(-1, 2))
        for name in ("colours", "sizes"):
            object.__setattr__(self, name, frozen_array(getattr(self, name), np.int64))
