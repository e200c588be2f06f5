"""Rendering a recording's map states to PNG frames (and a movie), outside any run."""

from __future__ import annotations

import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

from common.config import AppConfig
from common.errors import FsdError
from common.messages import ActuatorCommand, GroundTruth, MapState, Plan
from visualiser.frame_data import frame_from_messages, track_data
from visualiser.movie import make_movie
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


def render_recording(path: Path, out_dir: Path, config: AppConfig, fps: float | None = None,
                     movie: Path | None = None, progress: bool = False) -> dict[str, Any]:
    """Draw every map state (or ``fps`` of them per second of recording time) to ``out_dir``."""
    from recordings.player import Player
    from recordings.topics import COMMAND, MAP_STATE, PLAN, TRUTH_POSE, TRUTH_TRACK

    if not path.exists():
        raise FsdError(f"{path}: no such recording")
    vis = config.visualiser
    out_dir.mkdir(parents=True, exist_ok=True)
    renderer = FrameRenderer(vis.width_px, vis.height_px, vis.view, vis.follow_span_m,
                             vis.png_compress_level)
    writer = PngWriter(renderer)
    plan: Plan | None = None
    command: ActuatorCommand | None = None
    truth: GroundTruth | None = None
    frames: list[Path] = []
    next_t = -1.0
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(desc="render", unit="frame")
    wall0 = time.perf_counter()
    for t_s, topic, message in Player(path, rate=None,
                                      topics=[MAP_STATE, PLAN, COMMAND, TRUTH_POSE, TRUTH_TRACK]):
        if isinstance(message, Plan):
            plan = message
        elif isinstance(message, ActuatorCommand):
            command = message
        elif isinstance(message, GroundTruth):
            truth = message
        elif topic == TRUTH_TRACK and vis.show_truth:
            renderer.track = track_data(message)
        elif topic == MAP_STATE and isinstance(message, MapState):
            if fps is not None and t_s < next_t - 1e-6:  # float steps of the 10 Hz states
                continue
            next_t = t_s + (1.0 / fps if fps else 0.0)
            frame = frame_from_messages(message, plan, command,
                                        truth if vis.show_truth else None)
            renderer.render(frame)
            target = out_dir / frame_file_name(t_s)
            writer.write(target)
            frames.append(target)
            if bar is not None:
                bar.update(1)
    writer.close()
    if bar is not None:
        bar.close()
    wall_s = time.perf_counter() - wall0
    if not frames:
        raise FsdError(f"{path}: has no map states to render")
    result: dict[str, Any] = {"frames": len(frames), "fps": len(frames) / max(wall_s, 1e-9)}
    if movie is not None:
        result["movie"] = str(make_movie(frames, movie, fps or vis.movie_fps))
    return result
