"""Configuration of the Mapper: backend choice and each estimator's parameters."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal


@dataclass(slots=True)
class SmootherConfig:
    """Seed 002, table 2: the time smoother's optimal parameters."""

    size_ratio_x: float = 0.7
    size_ratio_y: float = 0.7
    match_distance_m: float = 1.5
    conf_limit: float = 20.0
    confidence_decay: float = 1.0
    match_conf: float = 2.0
    initial_conf: float = 2.0


@dataclass(slots=True)
class MapperConfig:
    """Which backend maps, and its parameters."""

    backend: Literal["slam", "smoother"] = "slam"
    smoother: SmootherConfig = field(default_factory=SmootherConfig)
