"""Movies from PNG frames: MP4 through imageio-ffmpeg's bundled ffmpeg, GIF through Pillow."""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from common.errors import FsdError

log = logging.getLogger(__name__)

STREAM_SUFFIXES = (".mp4", ".mkv", ".webm")
"""Movies :class:`MovieStream` writes (a GIF is made from the PNG frames at the end)."""


def make_movie(frames: list[Path], out_path: Path, fps: float = 10.0) -> Path:
    """Write ``frames`` (PNG paths, in order) as a movie; the suffix picks MP4 or GIF."""
    if not frames:
        raise FsdError(f"{out_path}: no frames to make a movie of")
    from PIL import Image

    suffix = out_path.suffix.lower()
    out_path.parent.mkdir(parents=True, exist_ok=True)
    if suffix == ".gif":
        images = [Image.open(p).convert("P", palette=Image.Palette.ADAPTIVE) for p in frames]
        images[0].save(out_path, save_all=True, append_images=images[1:],
                       duration=int(round(1000.0 / fps)), loop=0)
        return out_path
    if suffix not in STREAM_SUFFIXES:
        raise FsdError(f"{out_path}: movie must end in .mp4 or .gif")
    stream = MovieStream(out_path, fps)
    for path in frames:
        with Image.open(path) as image:
            stream.add(np.asarray(image.convert("RGB")))
    if not stream.close():
        raise FsdError(f"{out_path}: the movie could not be written (see the log)")
    return out_path


class MovieStream:
    """A movie written frame by frame as the frames are drawn, through imageio-ffmpeg's bundled
    ffmpeg (H.264), so a run's movie is done when its last frame is: ffmpeg encodes in its own
    process beside the run. It writes ``<name>.part`` and renames it when closed whole; a frame
    it cannot take (ffmpeg missing or gone, a frame of another size) is logged once and ends
    the stream, deleting the part: whoever made the frames may make the movie from the PNGs."""

    def __init__(self, out_path: Path, fps: float = 10.0) -> None:
        if out_path.suffix.lower() not in STREAM_SUFFIXES:
            raise FsdError(f"{out_path}: a streamed movie must end in "
                           f"{', '.join(STREAM_SUFFIXES)}")
        self.out_path = out_path
        self.part_path = out_path.with_name(out_path.name + ".part")
        self.fps = fps
        self.frames = 0
        self.failed = False
        self._writer: Any = None
        self._size: tuple[int, int] | None = None

    def add(self, rgb: NDArray[np.uint8]) -> bool:
        """Append one frame, (height, width, 3) RGB; False once the stream has failed."""
        if self.failed:
            return False
        try:
            height, width = rgb.shape[:2]
            if self._writer is None:
                import imageio_ffmpeg

                # H.264 wants even sizes
                self._size = (width - width % 2, height - height % 2)
                self.out_path.parent.mkdir(parents=True, exist_ok=True)
                self._writer = imageio_ffmpeg.write_frames(
                    str(self.part_path), self._size, fps=self.fps, codec="libx264",
                    quality=6, macro_block_size=2, ffmpeg_log_level="error",
                    output_params=["-f", self.out_path.suffix.lower().lstrip(".")
                                   .replace("mkv", "matroska")])
                self._writer.send(None)
            assert self._size is not None
            even_w, even_h = self._size
            if width < even_w or height < even_h:
                raise ValueError(f"a frame of {width}x{height} in a {even_w}x{even_h} movie")
            self._writer.send(np.ascontiguousarray(rgb[:even_h, :even_w]))
            self.frames += 1
            return True
        except Exception:  # the movie is a convenience: the frames stand without it
            log.exception("%s: frame %d could not be added; no movie streamed", self.out_path,
                          self.frames)
            self._fail()
            return False

    def close(self) -> bool:
        """Finish the movie; True when it was written whole (False: none, or it failed)."""
        if self.failed or self._writer is None:
            return False
        try:
            self._writer.close()
        except Exception:
            log.exception("%s: could not be finished", self.out_path)
            self._fail()
            return False
        self._writer = None
        self.part_path.replace(self.out_path)
        return True

    def _fail(self) -> None:
        self.failed = True
        writer, self._writer = self._writer, None
        if writer is not None:
            try:
                writer.close()
            except Exception:  # noqa: BLE001 (already failing: the first error is logged)
                pass
        self.part_path.unlink(missing_ok=True)


def frames_in(folder: Path) -> list[Path]:
    """The frame files of a folder, in time order."""
    return sorted(folder.glob("frame_*.png"))
