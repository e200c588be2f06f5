"""Localisation on the frozen map (seed 001): after the loop closure the UKF takes every reading
and each LiDAR sweep's cones are matched to the map's; camera cones still vote for the map
cones' colours (the map's positions no longer change)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from scipy.spatial import cKDTree

from common.messages import ConeColour, ConeDetection, ConeMap
from mapper.backend import SweepResult, UkfInputs
from mapper.object_filter import localise_objects
from mapper.time_smoother import N_COLOURS
from mapper.ukf_localiser import UkfLocaliser


class MapLocaliser(UkfInputs):
    """The UKF on ``cone_map`` (the Mapper's estimator after the freeze); camera colours vote
    for the nearest map cone within ``colour_gate_m``, the map's own colours counting 3 votes."""

    def __init__(self, ukf: UkfLocaliser, cone_map: ConeMap, colour_gate_m: float) -> None:
        super().__init__(ukf)
        self.map = cone_map
        self.colour_gate_m = colour_gate_m
        votes = np.zeros((len(cone_map), N_COLOURS))
        known = cone_map.colour > int(ConeColour.UNKNOWN)
        votes[np.flatnonzero(known), cone_map.colour[known]] = 3.0
        self.votes = votes

    def update_lidar(self, cones: Sequence[ConeDetection], timestamp_s: float,
                     odometer_m: float) -> SweepResult:
        if cones:
            self.ukf.update_cones_on_map(cones, self.map, self.compensated(cones, timestamp_s))
        return SweepResult(map_changed=False)

    def add_colours(self, cones: Sequence[ConeDetection]) -> bool:
        if len(self.map) == 0:
            return False
        x = self.ukf.x
        xy = localise_objects(cones, float(x[0]), float(x[1]), float(x[2]))
        colours = np.array([int(c.colour) for c in cones], np.int64)
        weights = np.array([min(max(c.confidence, 0.0), 1.0) for c in cones])
        dist, idx = cKDTree(self.map.xy_m).query(xy, k=1, distance_upper_bound=self.colour_gate_m)
        ok = np.isfinite(dist)
        np.add.at(self.votes, (np.asarray(idx)[ok], colours[ok]), weights[ok])
        return True

    def cone_map(self) -> ConeMap:
        """The frozen map with each cone's colour by vote."""
        fm = self.map
        votes = self.votes
        colour = np.where(votes.max(axis=1) > 0.0, np.argmax(votes, axis=1),
                          int(ConeColour.UNKNOWN)) if len(fm) else fm.colour
        return ConeMap(fm.xy_m, fm.covariance, colour, fm.size, fm.confidence, fm.ids)
