"""Configuration of the Visualiser."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal


@dataclass(slots=True)
class VisualiserConfig:
    """Off-screen frames of the map, drawn beside the loop."""

    width_px: int = 1280
    height_px: int = 720
    fps: float = 2.0
    """Frames per second of simulated time rendered during a run."""
    view: Literal["track", "follow"] = "track"
    """'track': the whole track fits the frame; 'follow': a window around the car."""
    follow_span_m: float = 40.0
    """Width of the follow view (m)."""
    queue_length: int = 4
    """Frames waiting for the renderer; when full, new frames are dropped (never waits)."""
    png_compress_level: int = 1
    """zlib level of the PNG writer: 1 is fast, 9 small."""
    movie: str = "movie.mp4"
    """Movie made from a run's frames ('' for none; .mp4 needs ffmpeg, .gif does not)."""
    movie_fps: float = 10.0
    """Playback frames per second of the movie."""
    window: bool = False
    """Also show the frames in a window, when a display exists (the car's screen, a laptop)."""
    show_truth: bool = True
    """Draw the true cones and pose, faint, when known (simulation)."""
