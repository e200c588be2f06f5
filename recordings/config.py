"""Configuration of the recorder."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(slots=True)
class RecordingConfig:
    """MCAP recording."""

    enabled: bool = True
    queue_length: int = 20000
    """Messages the recorder's queue holds (a tick's raw units go in as one batch, but each
    counts); when it is full, new messages are dropped (counted), or, when recording a
    simulation or replay, the caller waits for room."""
    chunk_duration_s: float = 0.4
    """A chunk is closed (compressed, written, flushed) once it spans this much log time or has
    been open this long on the wall clock: at most about this much is lost on a hard kill
    (SIGKILL, a crash). 0.4 s keeps the loss under 0.5 s with room for the writer's queue."""
    chunk_size_bytes: int = 4 * 1024 * 1024
    """A chunk is also closed when its uncompressed messages reach this size."""
    foxglove: bool = True
    """Also write the Foxglove views: /foxglove/scene (foxglove.SceneUpdate), /foxglove/tf
    (foxglove.FrameTransform) and /foxglove/gps (foxglove.LocationFix)."""
    foxglove_scene_period_s: float = 0.05
    """Least log time between two scene updates of the map (0: one per map state)."""
    stop_timeout_s: float = 10.0
    """How long close() waits for the writer thread to drain the queue and finish the file."""
