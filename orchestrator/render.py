"""Frames (and a movie) of a recording's map (``python main.py render X.mcap --out DIR``).

Main's work: it reads the recording (the player) and hands the messages to the visualiser's
:class:`~visualiser.offline.FrameWriter`.
"""

from __future__ import annotations

import math
import time
from pathlib import Path
from typing import Any

from common.errors import FsdError
from common.messages import MapState
from orchestrator.progress import Progress
from recordings.player import Player
from recordings.reader import RecordingReader
from recordings.topics import COMMAND, MAP_STATE, PLAN, TRUTH_POSE, TRUTH_TRACK
from visualiser.config import VisualiserConfig
from visualiser.movie import make_movie
from visualiser.offline import FrameWriter


def render_recording(path: Path, out_dir: Path, config: VisualiserConfig,
                     fps: float | None = None, movie: Path | None = None,
                     progress: bool = False) -> dict[str, Any]:
    """Draw every map state (or ``fps`` of them per second of recording time) to ``out_dir``;
    ``progress``: a bar (on a terminal), else a plain progress line every few seconds."""
    if not path.exists():
        raise FsdError(f"{path}: no such recording")
    writer = FrameWriter(config, out_dir)
    from orchestrator.replay import recorded_config

    recorded = recorded_config(path) or {}
    laps = recorded.get("mission", {}).get("laps", 0)
    writer.laps_target = laps if isinstance(laps, int) else 0
    next_t = -1.0
    with RecordingReader(path) as reader:
        end_ns = reader.last_log_time_ns(MAP_STATE)
    end_s = math.ceil(end_ns * 1e-9) if end_ns is not None else None
    bar = Progress("render", end_s, "s of recording", progress)
    wall0 = time.perf_counter()
    for t_s, topic, message in Player(path, rate=None,
                                      topics=[MAP_STATE, PLAN, COMMAND, TRUTH_POSE, TRUTH_TRACK]):
        if topic == TRUTH_TRACK:
            writer.set_track(message)
        elif topic == MAP_STATE and isinstance(message, MapState):
            if fps is not None and t_s < next_t - 1e-6:  # float steps of the 10 Hz states
                writer.note(message)  # its pose joins the trace
                continue
            next_t = t_s + (1.0 / fps if fps else 0.0)
            writer.draw(t_s, message)
            bar.update(int(t_s), lambda: f"{len(writer.frames)} frames, "
                       f"{len(writer.frames) / max(bar.wall_s, 1e-9):.1f} frames/s")
        else:
            writer.note(message)
    writer.close()
    bar.close()
    wall_s = time.perf_counter() - wall0
    frames = writer.frames
    if not frames:
        raise FsdError(f"{path}: has no map states to render")
    result: dict[str, Any] = {"frames": len(frames), "fps": len(frames) / max(wall_s, 1e-9)}
    if movie is not None:
        result["movie"] = str(make_movie(frames, movie, fps or config.movie_fps))
    return result
