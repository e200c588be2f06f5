"""Configuration of the recorder."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(slots=True)
class RecordingConfig:
    """MCAP recording."""

    enabled: bool = True
    queue_length: int = 20000
    chunk_duration_s: float = 1.0
