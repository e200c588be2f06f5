"""The ``smoother`` mapping backend: seed 002's pipeline beside seed 001's UKF.

The UKF gives the pose; each LiDAR sweep's objects are put in the world at that pose (object
localisation) and merged by the time smoother. With ``fusion.smoother_localise`` the UKF also
localises on the objects the smoother has confirmed, before the sweep is merged into them (a
SLAM without cross-covariances). The loop closes when the car is back within
``fusion.loop_close_radius_m`` of the start after ``fusion.loop_min_distance_m`` of travel.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Sequence

import numpy as np

from common.car import CarConfig
from common.conventions import vehicle_to_world
from common.messages import ConeDetection, ConeMap
from mapper.backend import SweepResult, UkfInputs
from mapper.config import MapperConfig
from mapper.object_filter import detection_sizes, localise_objects
from mapper.time_smoother import TimeSmoother
from mapper.ukf_localiser import UkfLocaliser

log = logging.getLogger(__name__)


class SmootherBackend(UkfInputs):
    """The time smoother and the UKF behind the Mapper's backend protocol
    (:class:`mapper.backend.MappingBackend`)."""

    name = "smoother"
    refines_gnss_frame = False
    owns_map_errors = False

    def __init__(self, config: MapperConfig, car: CarConfig, ukf: UkfLocaliser) -> None:
        super().__init__(ukf)
        self.config = config
        self.car = car
        self.smoother = TimeSmoother(config.smoother)

    def update_lidar(self, cones: Sequence[ConeDetection], timestamp_s: float,
                     odometer_m: float) -> SweepResult:
        low = self.config.smoother.min_height_m
        cones = [c for c in cones if not c.height_m < low]
        if not cones:
            return SweepResult(map_changed=False)
        xy_vehicle = self.compensated(cones, timestamp_s)
        fc = self.config.fusion
        x = self.ukf.x
        if fc.smoother_localise:
            # SLAM without cross-covariances: localise on the objects the smoother has
            # confirmed, then add this sweep to them.
            confirmed = self.smoother.confirmed_map(fc.smoother_localise_min_matches,
                                                    fc.smoother_localise_map_sigma_floor_m)
            if len(confirmed):
                self.ukf.update_cones_on_map(cones, confirmed, xy_vehicle,
                                             full_update=fc.smoother_localise_full_update,
                                             cone_sigma_m=fc.smoother_localise_sigma_m)
                x = self.ukf.x
        pose = (float(x[0]), float(x[1]), float(x[2]))
        xy_world = vehicle_to_world(xy_vehicle, *pose).reshape(-1, 2)
        lidar = vehicle_to_world([self.car.lidar_x_m, 0.0], *pose).reshape(2)
        colours = np.array([int(c.colour) for c in cones], np.int64)
        self.smoother.update(xy_world, detection_sizes(cones),
                             (float(lidar[0]), float(lidar[1]), pose[2]), colours)
        closed = (odometer_m >= fc.loop_min_distance_m
                  and math.hypot(pose[0], pose[1]) <= fc.loop_close_radius_m)
        if closed:
            log.info("smoother loop closed after %.1f m", odometer_m)
        return SweepResult(map_changed=True, loop_closed=closed)

    def add_colours(self, cones: Sequence[ConeDetection]) -> bool:
        x = self.ukf.x
        xy = localise_objects(cones, float(x[0]), float(x[1]), float(x[2]))
        colours = np.array([int(c.colour) for c in cones], np.int64)
        weights = np.array([min(max(c.confidence, 0.0), 1.0) for c in cones])
        self.smoother.add_colour_votes(xy, colours, self.config.fusion.colour_gate_m, weights)
        return True

    def cone_map(self) -> ConeMap:
        return self.smoother.cone_map()

    def hand_over(self, cone_map: ConeMap, own_map: bool) -> ConeMap:
        """Nothing to hand over: the UKF has localised all along."""
        return cone_map

    def stats(self) -> dict[str, dict[str, int]]:
        return {}
