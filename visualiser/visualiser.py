"""The Visualiser: renders frames beside the control loop, in its own process.

``submit`` turns the messages into a small :class:`~visualiser.frame_data.FrameData` and puts
it on a bounded queue without waiting: when the renderer is behind, the frame is dropped and
counted, so drawing never delays a control tick. The renderer process draws on an off-screen
pygame Surface and writes PNG files named by the frame's time (``frame_<ms>.png``), and, when
asked, streams them into a movie as it goes. Running in a process (not a thread) keeps the
drawing off the loop's GIL.
"""

from __future__ import annotations

import logging
import math
import multiprocessing as mp
import os
import queue
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from common.messages import ActuatorCommand, GroundTruth, Health, MapState, Plan
from visualiser.config import VisualiserConfig
from visualiser.frame_data import FrameData, TrackData, frame_from_messages, track_data
from visualiser.laps import LapTimer
from visualiser.movie import MovieStream

log = logging.getLogger(__name__)


LEGEND_FRAC = 0.26
"""Width of the strip kept for the legend on the left, as a fraction of the frame's height."""
COLOUR_BAR_FRAC = 0.1
"""Width of the strip kept for the speed colour bar on the right (fraction of the height)."""


def frame_file_name(t_s: float) -> str:
    """``frame_<milliseconds, 9 digits>.png``: files sort by time."""
    return f"frame_{int(round(t_s * 1000.0)):09d}.png"


class FrameRenderer:
    """Draws frames on one off-screen Surface and writes them as PNG (synchronous)."""

    def __init__(self, width_px: int, height_px: int, view: str = "track",
                 follow_span_m: float = 40.0, png_compress_level: int = 1) -> None:
        os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
        import pygame

        from visualiser import renderer

        self._pygame = pygame
        self._renderer = renderer
        self.surface = pygame.Surface((width_px, height_px))
        self.view_kind = view
        self.follow_span_m = follow_span_m
        self.png_compress_level = png_compress_level
        self.track: TrackData | None = None
        self.trace: list[tuple[float, float]] = []
        self.trace_speed_mps: list[float] = []
        self._trace_array = np.zeros((0, 2))

    def view_for(self, frame: FrameData) -> Any:
        """The world-to-pixel transform for this frame (whole track, or following the car)."""
        from visualiser.transform import WorldToPixel

        w, h = self.surface.get_size()
        if self.view_kind == "follow":
            return WorldToPixel.follow(w, h, frame.pose[0], frame.pose[1], self.follow_span_m)
        parts = [frame.cones_xy_m.reshape(-1, 2), np.array([frame.pose[:2]])]
        if self.track is not None:
            parts.append(self.track.cones_xy_m)
        if len(self._trace_array):
            parts.append(self._trace_array)
        # The track fits between the legend (left) and the speed colour bar (right).
        left_px, right_px = int(LEGEND_FRAC * h), int(COLOUR_BAR_FRAC * h)
        inner = WorldToPixel.fit(max(w - left_px - right_px, 1), h, np.concatenate(parts))
        shift_m = 0.5 * (left_px - right_px) / inner.px_per_m
        return WorldToPixel(w, h, inner.centre_x_m - shift_m, inner.centre_y_m, inner.px_per_m)

    def render(self, frame: FrameData, hud_extra: tuple[str, ...] = ()) -> Any:
        """Draw ``frame`` (adding its poses to the driven trace); returns the Surface."""
        self.trace.extend((float(x), float(y)) for x, y in frame.trace_xy_m)
        speeds = np.asarray(frame.trace_speed_mps, dtype=float)
        if len(speeds) != len(frame.trace_xy_m):
            speeds = np.full(len(frame.trace_xy_m), frame.speed_mps)
        self.trace_speed_mps.extend(speeds.tolist())
        self.trace.append((frame.pose[0], frame.pose[1]))
        self.trace_speed_mps.append(frame.speed_mps)
        self._trace_array = np.asarray(self.trace)
        self._renderer.draw_frame(self.surface, frame, self.view_for(frame), self.track,
                                  self._trace_array, hud_extra,
                                  trace_speed_mps=np.asarray(self.trace_speed_mps))
        return self.surface

    def rgb(self) -> NDArray[np.uint8]:
        """The Surface's pixels, (height, width, 3) RGB."""
        w, h = self.surface.get_size()
        data = self._pygame.image.tobytes(self.surface, "RGB")
        return np.frombuffer(data, dtype=np.uint8).reshape(h, w, 3)

    def save_png(self, path: Path, rgb: NDArray[np.uint8] | None = None) -> None:
        """Write the Surface (or its ``rgb`` pixels, taken already) as PNG (Pillow, fast zlib
        level)."""
        from PIL import Image

        Image.fromarray(self.rgb() if rgb is None else rgb, "RGB").save(
            path, compress_level=self.png_compress_level)


def _open_window(width_px: int, height_px: int) -> Any:
    """A resizable window when a display exists, else None (frames are still written)."""
    if not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        logging.getLogger(__name__).warning("visualiser.window asked for, but no display: off")
        return None
    os.environ["SDL_VIDEODRIVER"] = os.environ.get("FSD_SDL_VIDEODRIVER", "x11")
    import pygame

    pygame.display.init()
    window = pygame.display.set_mode((width_px, height_px), pygame.RESIZABLE)
    pygame.display.set_caption("fsd-stack map")
    return window


def _render_worker(jobs: Any, out_dir: str, width_px: int, height_px: int, view: str,
                   follow_span_m: float, png_compress_level: int, window: bool = False,
                   movie_path: str | None = None, movie_fps: float = 10.0) -> None:
    """Renderer process: draw and save every frame it is given until ``None`` arrives; with
    ``movie_path``, stream the frames into that movie too (finished when ``None`` arrives)."""
    try:
        os.nice(10)  # drawing yields the CPU to the control loop, never the other way round
    except OSError:
        pass
    screen = _open_window(width_px, height_px) if window else None
    renderer = FrameRenderer(width_px, height_px, view, follow_span_m, png_compress_level)
    target = Path(out_dir)
    target.mkdir(parents=True, exist_ok=True)
    movie = MovieStream(Path(movie_path), movie_fps) if movie_path else None
    while True:
        job = jobs.get()
        if job is None:
            if movie is not None:
                movie.close()
            break
        kind, payload = job
        if kind == "track":
            renderer.track = payload
            continue
        try:
            surface = renderer.render(payload)
            rgb = renderer.rgb()
            renderer.save_png(target / frame_file_name(payload.t_s), rgb)
            if movie is not None:
                movie.add(rgb)
            if screen is not None:
                import pygame

                pygame.event.pump()
                size = pygame.display.get_surface().get_size()
                pygame.display.get_surface().blit(pygame.transform.smoothscale(surface, size),
                                                  (0, 0))
                pygame.display.flip()
        except Exception:  # a bad frame must not kill the renderer
            logging.getLogger(__name__).exception("frame at t=%s failed", payload.t_s)


class Visualiser:
    """Renders map frames to ``out_dir`` in a separate process; ``submit`` never blocks."""

    def __init__(self, config: VisualiserConfig, out_dir: Path | str, laps: int = 0,
                 movie_path: Path | None = None) -> None:
        """``movie_path``: the renderer streams its frames into this movie as it draws them
        (an ``.mp4``, ``.mkv`` or ``.webm``; :class:`~visualiser.movie.MovieStream`), done when
        :meth:`close` returns."""
        vis = config
        self.out_dir = Path(out_dir)
        self.out_dir.mkdir(parents=True, exist_ok=True)
        ctx = mp.get_context("spawn")
        self._jobs: Any = ctx.Queue(maxsize=max(1, vis.queue_length))
        self._process = ctx.Process(
            target=_render_worker, name="visualiser",
            args=(self._jobs, str(self.out_dir), vis.width_px, vis.height_px, vis.view,
                  vis.follow_span_m, vis.png_compress_level, vis.window,
                  str(movie_path) if movie_path is not None else None, vis.movie_fps),
            daemon=True,
        )
        self._process.start()
        self._track_sent = False
        self._trace: list[tuple[float, float, float]] = []
        self.laps = LapTimer()
        self.laps_target = laps
        self.submitted = 0
        self.dropped = 0
        self.config = config

    def note_pose(self, x_m: float, y_m: float, speed_mps: float = math.nan,
                  t_s: float | None = None, lap: int = 0, driving: bool = False) -> None:
        """Remember a pose and its speed for the driven trace between frames, and time the laps
        (``lap``: the plan's laps completed; ``driving``: AS state DRIVING) (cheap; ~10 Hz)."""
        if len(self._trace) < 10000:
            self._trace.append((x_m, y_m, speed_mps))
        if t_s is not None:
            self.laps.observe(t_s, lap, driving, speed_mps)

    def submit(
        self,
        map_state: MapState,
        plan: Plan | None = None,
        command: ActuatorCommand | None = None,
        truth: GroundTruth | None = None,
        track: Any = None,
        health: Health | None = None,
    ) -> bool:
        """Queue a frame; returns False (and counts it) when the renderer is behind."""
        if not self._track_sent and track is not None and self.config.show_truth:
            td: TrackData | None = track_data(track)
            try:
                self._jobs.put_nowait(("track", td))
                self._track_sent = True
            except queue.Full:
                pass
        if not self.config.show_truth:
            truth = None
        frame = frame_from_messages(map_state, plan, command, truth, health)
        if self._trace:
            trace = np.asarray(self._trace)
            frame.trace_xy_m = trace[:, :2]
            frame.trace_speed_mps = trace[:, 2]
        frame.lap = max(frame.lap, self.laps.lap)
        frame.laps_target = self.laps_target
        frame.lap_times_s = tuple(self.laps.lap_times_s)
        try:
            self._jobs.put_nowait(("frame", frame))
        except queue.Full:
            self.dropped += 1
            return False
        self._trace = []
        self.submitted += 1
        return True

    def close(self, timeout_s: float = 60.0) -> None:
        """Let the renderer finish the queued frames, then stop it."""
        if not self._process.is_alive():
            return
        try:
            self._jobs.put(None, timeout=timeout_s)
        except queue.Full:
            log.warning("visualiser queue stuck: terminating the renderer")
        self._process.join(timeout_s)
        if self._process.is_alive():
            self._process.terminate()
            self._process.join(1.0)
        if self.dropped:
            log.info("visualiser dropped %d of %d frames", self.dropped,
                     self.dropped + self.submitted)

    def __enter__(self) -> Visualiser:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
