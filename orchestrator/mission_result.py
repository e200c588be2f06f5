"""The per-mission result of a run for ``summary.json``: the event's times against the friction
limit.

Every mission reports ``mission_time_s`` (the RES go to the car standing finished).
Trackdrive and autocross add the lap driven on the unseen track (``explored_lap_s``), the
friction-limited minimum lap of the true centreline (``min_lap_s``) and their ratio
(``explored_ratio``), the same lap's minimum from a standstill (``min_standing_lap_s``: the
explored lap is timed from the go, a standing start) and the ratio to it
(``explored_standing_ratio``); with the seen track ahead of the car while it explored (its median,
``explored_view_m``), the speed stopping within that allows (``view_speed_mps``) and the
ratio of a lap held to it to the same minimum (``view_ceiling_ratio``: what that much in view
allows at best, ``bench ceiling``). Acceleration adds its time over the 75 m and skidpad
its laps, each side's timed lap and their mean (:class:`simulator.mission_timing.MissionTimer`,
ground truth), each against the friction-limited minimum of the same point mass trackdrive's
best lap is compared with (:mod:`planner.speed_profile`: 1.5 g lateral, 8 m/s^2 drive,
12 m/s^2 brake, 25 m/s, from the car's configuration) on the true layout: from standstill over
the same 75 m, and a flying lap of the circle through the middle of each skidpad lane.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from common.car import CarConfig
from common.messages import ConeColour
from planner.skidpad_path import fit_centre
from planner.speed_profile import min_lap_time_s, min_run_time_s, min_standing_lap_time_s
from simulator.mission_timing import MissionTimer
from simulator.track import Track

TIMED_MISSIONS = ("acceleration", "skidpad")
"""Missions timed on their own lines (the others by their laps)."""


def mission_timer(mission: str, track: Track, car: CarConfig) -> MissionTimer | None:
    """The ground-truth timer of an acceleration or skidpad run on a layout of that kind."""
    if mission not in TIMED_MISSIONS or track.kind != mission:
        return None
    return MissionTimer.for_track(track, car.length_m - car.rear_overhang_m)


def mission_result(mission: str, track: Track, car: CarConfig, timer: MissionTimer | None,
                   mission_time_s: float | None, explored_lap_s: float | None = None,
                   explored_view: tuple[float, float] | None = None) -> dict[str, Any]:
    """The mission's result (see the module docstring); ``mission_time_s``: go to finished
    standstill (s; None when the run did not finish); ``explored_lap_s``: the lap driven on
    the unseen track (trackdrive's first, autocross's only; None when there was none);
    ``explored_view``: (the median seen track ahead of the car while exploring (m), the speed
    (m/s) stopping within it allows; :meth:`planner.path_planner.PathPlanner.explored_view`)."""
    result: dict[str, Any] = {"mission_time_s": _round(mission_time_s)}
    if timer is None:
        if (mission in ("trackdrive", "autocross") and explored_lap_s is not None
                and math.isfinite(explored_lap_s)):
            t_min = min_lap_time_s(track.centreline_xy_m, car)
            result["explored_lap_s"] = _round(explored_lap_s)
            result["min_lap_s"] = _round(t_min)
            result["explored_ratio"] = _ratio(explored_lap_s, t_min)
            t_standing = min_standing_lap_time_s(track.centreline_xy_m, car)
            result["min_standing_lap_s"] = _round(t_standing)
            result["explored_standing_ratio"] = _ratio(explored_lap_s, t_standing)
            if explored_view is not None:
                view_m, speed_mps = explored_view
                ceiling = min_lap_time_s(track.centreline_xy_m, car, max_speed_mps=speed_mps)
                result["explored_view_m"] = _round(view_m, 2)
                result["view_speed_mps"] = _round(speed_mps, 2)
                result["view_ceiling_ratio"] = _ratio(ceiling, t_min)
        return result
    result.update(timer.result())
    front_m = car.length_m - car.rear_overhang_m
    if mission == "acceleration":
        s_start, s_finish = (_along_m(track, line) for line in (track.start_line_xy_m,
                                                                 track.finish_line_xy_m))
        t_min = min_run_time_s(track.centreline_xy_m, car, s_start - front_m, s_finish - front_m)
        result["distance_m"] = _round(s_finish - s_start, 2)
        result["min_time_s"] = _round(t_min)
        result["ratio"] = _ratio(result.get("time_s"), t_min)
        return result
    minima = skidpad_min_laps_s(track, car)
    result["min_right_lap_s"] = _round(minima["right"])
    result["min_left_lap_s"] = _round(minima["left"])
    result["min_mean_lap_s"] = _round(0.5 * (minima["right"] + minima["left"]))
    result["ratio"] = _ratio(result.get("mean_timed_lap_s"), result["min_mean_lap_s"])
    return result


def skidpad_min_laps_s(track: Track, car: CarConfig, inner_diameter_m: float = 15.25,
                       lane_width_m: float = 3.0) -> dict[str, float]:
    """Friction-limited flying lap (s) of each skidpad circle (``right``, ``left``): the circle
    through the middle of its lane, its centre and rings fitted to the true cones (the rules'
    radii as the first guess)."""
    xy = track.cones_xy_m
    big = track.colours == int(ConeColour.BIG_ORANGE)
    line = track.start_line_xy_m
    gate = line.mean(axis=0) if np.all(np.isfinite(line)) else xy[big].mean(axis=0)
    r_in = 0.5 * inner_diameter_m
    r_mid = r_in + 0.5 * lane_width_m
    # the car starts at the origin facing +x (the world frame): left is +y
    out: dict[str, float] = {}
    for name, sign in (("right", -1.0), ("left", 1.0)):
        side = (xy[:, 1] - gate[1]) * sign > 0.0
        pts = xy[side & ~big]
        centre, _ = fit_centre(pts, gate + np.array([0.0, sign * r_mid]),
                               (r_in, r_in + lane_width_m))
        dist = np.hypot(*(pts - centre).T)
        inner = dist[np.abs(dist - r_in) < 1.0]
        outer = dist[np.abs(dist - r_in - lane_width_m) < 1.0]
        radius = (0.5 * (float(np.median(inner)) + float(np.median(outer)))
                  if len(inner) and len(outer) else r_mid)
        angle = np.linspace(0.0, 2.0 * math.pi, 360, endpoint=False)
        circle = np.stack([radius * np.cos(angle), radius * np.sin(angle)], axis=1)
        out[name] = min_lap_time_s(circle, car)
    return out


def _along_m(track: Track, line_xy_m: np.ndarray) -> float:
    """Arc length (m) along the track's centreline where a line crosses it (its middle)."""
    mid = np.asarray(line_xy_m, np.float64).mean(axis=0)
    return float(track.progress_m(float(mid[0]), float(mid[1])))


def _ratio(value: float | None, minimum: float | None) -> float | None:
    if value is None or minimum is None or not minimum > 0.0:
        return None
    return round(value / minimum, 3)


def _round(value: float | None, digits: int = 3) -> float | None:
    return None if value is None or not math.isfinite(value) else round(value, digits)
