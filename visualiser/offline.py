"""Frames of map states drawn off-screen and written as PNG files, outside any run (``render``).

Main reads the recording and hands each message here (:class:`FrameWriter`); this module does
not know where the messages come from.
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

from common.messages import ActuatorCommand, AsState, GroundTruth, MapState, Plan
from visualiser.config import VisualiserConfig
from visualiser.frame_data import frame_from_messages, track_data
from visualiser.laps import LapTimer
from visualiser.visualiser import FrameRenderer, frame_file_name


class PngWriter:
    """Writes rendered frames on worker threads (Pillow's encoder releases the GIL)."""

    def __init__(self, renderer: FrameRenderer, threads: int = 2) -> None:
        self.renderer = renderer
        self.pool = ThreadPoolExecutor(max_workers=threads, thread_name_prefix="png")
        self.pending: list[Any] = []

    def write(self, path: Path) -> None:
        import pygame
        from PIL import Image

        size = self.renderer.surface.get_size()
        data = pygame.image.tobytes(self.renderer.surface, "RGB")
        level = self.renderer.png_compress_level

        def save() -> None:
            Image.frombytes("RGB", size, data).save(path, compress_level=level)

        self.pending.append(self.pool.submit(save))
        if len(self.pending) > 8:
            self.pending.pop(0).result()

    def close(self) -> None:
        for future in self.pending:
            future.result()
        self.pool.shutdown()


class FrameWriter:
    """Draws each map state handed to :meth:`draw` with the latest plan, command and truth handed
    to :meth:`note`, and writes it to ``out_dir`` as ``frame_<ms>.png``."""

    def __init__(self, config: VisualiserConfig, out_dir: Path) -> None:
        self.config = config
        self.out_dir = out_dir
        out_dir.mkdir(parents=True, exist_ok=True)
        self.renderer = FrameRenderer(config.width_px, config.height_px, config.view,
                                      config.follow_span_m, config.png_compress_level)
        self.writer = PngWriter(self.renderer)
        self.plan: Plan | None = None
        self.command: ActuatorCommand | None = None
        self.truth: GroundTruth | None = None
        self.speed_mps = 0.0
        self.laps = LapTimer()
        self._trace: list[tuple[float, float, float]] = []
        self.laps_target = 0
        """Laps the mission drove, when known (the recording's configuration)."""
        self.frames: list[Path] = []
        """The files written so far, in order."""

    def note(self, message: object) -> None:
        """Keep a plan, a command or the true pose for the frames that follow; a map state not
        drawn adds its pose and speed to the driven trace."""
        if isinstance(message, MapState):
            pose = message.pose
            self.speed_mps = pose.speed_mps
            self._trace.append((pose.x_m, pose.y_m, pose.speed_mps))
        elif isinstance(message, Plan):
            self.plan = message
            driving = self.command is not None and self.command.state == AsState.DRIVING
            self.laps.observe(message.timestamp_s, message.lap, driving, self.speed_mps)
        elif isinstance(message, ActuatorCommand):
            self.command = message
        elif isinstance(message, GroundTruth):
            self.truth = message

    def set_track(self, track: Any) -> None:
        """The true track (simulation only), drawn when ``show_truth`` is set."""
        if self.config.show_truth:
            self.renderer.track = track_data(track)

    def draw(self, t_s: float, map_state: MapState) -> Path:
        """Draw ``map_state`` (at ``t_s``, s) and write its PNG; returns the file."""
        frame = frame_from_messages(map_state, self.plan, self.command,
                                    self.truth if self.config.show_truth else None)
        self.speed_mps = map_state.pose.speed_mps
        if self._trace:
            trace = np.asarray(self._trace)
            frame.trace_xy_m, frame.trace_speed_mps = trace[:, :2], trace[:, 2]
            self._trace = []
        frame.lap = max(frame.lap, self.laps.lap)
        frame.laps_target = self.laps_target
        frame.lap_times_s = tuple(self.laps.lap_times_s)
        self.renderer.render(frame)
        target = self.out_dir / frame_file_name(t_s)
        self.writer.write(target)
        self.frames.append(target)
        return target

    def close(self) -> None:
        """Wait for every file to be written."""
        self.writer.close()
