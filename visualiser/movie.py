"""Movies from PNG frames: MP4 through imageio-ffmpeg's bundled ffmpeg, GIF through Pillow."""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np

from common.errors import FsdError

log = logging.getLogger(__name__)


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
    if suffix not in (".mp4", ".mkv", ".webm"):
        raise FsdError(f"{out_path}: movie must end in .mp4 or .gif")
    import imageio_ffmpeg

    first = Image.open(frames[0])
    width, height = first.size
    # H.264 wants even sizes.
    even_w, even_h = width - width % 2, height - height % 2
    writer = imageio_ffmpeg.write_frames(
        str(out_path), (even_w, even_h), fps=fps, codec="libx264", quality=6,
        macro_block_size=2, ffmpeg_log_level="error",
    )
    writer.send(None)
    for path in frames:
        rgb = np.asarray(Image.open(path).convert("RGB"))[:even_h, :even_w]
        writer.send(np.ascontiguousarray(rgb))
    writer.close()
    return out_path


def frames_in(folder: Path) -> list[Path]:
    """The frame files of a folder, in time order."""
    return sorted(folder.glob("frame_*.png"))
