"""Missions on a path known in advance (acceleration, skidpad): which builder, when it is done.

The Path Planner asks :class:`KnownPathMission` for the mission's :class:`MissionPath` from the
map as it grows (:mod:`planner.acceleration_path`, :mod:`planner.skidpad_path`), fits its
baseframe through it and plans the speed to a stop at its end. The mission is over when the
car, past the finish (the last timing line), has all but stopped: the controlled stop that
ends the run then takes centimetres, and the car stands where the path stops it.
"""

from __future__ import annotations

import logging
import math

from common.car import CarConfig
from common.messages import MapState
from planner.acceleration_path import acceleration_path
from planner.config import PlannerConfig
from planner.mission_path import MissionPath
from planner.skidpad_path import skidpad_path

logger = logging.getLogger(__name__)

KNOWN_PATH_MISSIONS = ("acceleration", "skidpad")
"""The missions driven on a path known from the rules' geometry."""


class KnownPathMission:
    """A mission's known path and its progress (see the module docstring).

    ``mission``: one of :data:`KNOWN_PATH_MISSIONS`. :meth:`start` once at the go (the car's
    pose then anchors the path), :meth:`build` whenever the map may have grown, :meth:`update`
    on every plan with the car's arc length along the frame.
    """

    def __init__(self, mission: str, config: PlannerConfig, car: CarConfig) -> None:
        if mission not in KNOWN_PATH_MISSIONS:
            raise ValueError(f"no known path for the mission {mission!r}")
        self.mission = mission
        self.config = config
        self.car = car
        self.start_pose: tuple[float, float, float] | None = None
        self.path: MissionPath | None = None
        self.done = False
        self._cones_seen = -1

    def start(self, x_m: float, y_m: float, yaw_rad: float) -> None:
        """The car's pose (m, m, rad) at the go: the path starts there."""
        self.start_pose = (x_m, y_m, yaw_rad)

    def build(self, map_state: MapState) -> MissionPath | None:
        """The path from the map when the map has changed since the last build (None: nothing
        new, or no path can be made yet, or the mission is over)."""
        cones = map_state.cones
        mapped = cones.ids >= 0  # the landmarks: the camera's tentative cones are for exploring
        xy, colour, size = cones.xy_m[mapped], cones.colour[mapped], cones.size[mapped]
        if self.start_pose is None or self.done or len(xy) == self._cones_seen:
            return None
        self._cones_seen = len(xy)
        c, car = self.config, self.car
        x, y, yaw = self.start_pose
        front = car.length_m - car.rear_overhang_m
        if self.mission == "acceleration":
            path = acceleration_path(
                xy, colour, size, (x, y), yaw,
                length_m=c.acceleration_length_m,
                stop_after_finish_m=c.acceleration_stop_after_finish_m,
                lane_width_m=c.acceleration_lane_width_m, front_m=front,
                end_clearance_m=c.mission_end_clearance_m)
        else:
            path = skidpad_path(
                xy, colour, size, (x, y), yaw,
                inner_diameter_m=c.skidpad_inner_diameter_m,
                lane_width_m=c.skidpad_lane_width_m,
                stop_after_centre_m=c.skidpad_stop_after_centre_m, front_m=front,
                end_clearance_m=c.mission_end_clearance_m)
        if path is not None:
            if self.path is None or path.complete != self.path.complete:
                logger.info("%s path: %.1f m, finish %.1f m, stop %.1f m%s", self.mission,
                            path.length_m, path.finish_s_m, path.stop_s_m,
                            "" if path.complete else " (the part seen so far)")
            self.path = path
        return path

    def update(self, s_m: float, scale: float, speed_mps: float) -> bool:
        """Feed the car's arc length ``s_m`` (m) along the frame, the frame's length over the
        path's (``scale``) and the car's speed (m/s); True once the mission is over."""
        path = self.path
        if self.done or path is None or not path.complete:
            return self.done
        past_finish = s_m >= path.finish_s_m * scale
        at_stop = s_m >= path.stop_s_m * scale - 0.3
        if past_finish and (speed_mps <= self.config.mission_done_speed_mps or at_stop):
            self.done = True
            logger.info("%s: finished at %.1f m (stop planned at %.1f m), %.2f m/s",
                        self.mission, s_m, path.stop_s_m * scale, speed_mps)
        return self.done

    def stop_s_m(self, scale: float) -> float:
        """Where the car is to stand (m along the frame); inf without a path."""
        return self.path.stop_s_m * scale if self.path is not None else math.inf

    @staticmethod
    def scale(frame_length_m: float, path: MissionPath) -> float:
        """Frame arc length per path arc length (the spline's length over the polyline's)."""
        return float(frame_length_m / max(path.length_m, 1e-9))

