"""Configuration of the Visualiser."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(slots=True)
class VisualiserConfig:
    """Off-screen frames."""

    width_px: int = 1280
    height_px: int = 720
    fps: float = 10.0
