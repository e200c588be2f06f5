"""Configuration of the simulator: track, seed and sensor noise."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(slots=True)
class SimConfig:
    """A closed-loop simulation run."""

    track: str = "default"
    seed: int = 1
    laps: int = 10
    physics_rate_hz: float = 200.0
    origin_lat_deg: float = 49.3269
    origin_lon_deg: float = 8.5654
    origin_alt_m: float = 100.0
    start_heading_enu_rad: float = 0.0
