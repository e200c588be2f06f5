"""Configuration of the Path Planner."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(slots=True)
class PlannerConfig:
    """Waypoints, baseframe, manoeuvres and speed profile."""

    waypoint_reach_m: float = 2.5
    rate_hz: float = 10.0
