"""Configuration of the Controller and the safety supervisor."""

from __future__ import annotations

from dataclasses import dataclass, field


@dataclass(slots=True)
class SafetyConfig:
    """When the safety supervisor stops the car."""

    plan_timeout_s: float = 0.2


@dataclass(slots=True)
class ControllerConfig:
    """Throttle and brake PIDs, steering law, rates."""

    rate_hz: float = 100.0
    safety: SafetyConfig = field(default_factory=SafetyConfig)
