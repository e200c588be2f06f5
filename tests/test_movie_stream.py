"""``MovieStream`` (issue 42): a movie written frame by frame through the bundled ffmpeg, renamed
into place only when whole; a frame it cannot take ends the stream without a partial file."""

from __future__ import annotations

import logging
from pathlib import Path

import imageio_ffmpeg
import numpy as np
import pytest

from common.errors import FsdError
from visualiser.movie import MovieStream, make_movie


def _frame(i: int, height: int = 51, width: int = 101) -> np.ndarray:
    rgb = np.zeros((height, width, 3), np.uint8)
    rgb[:, : (i * 7) % width] = (200, 40, 40)  # a bar that grows: frames differ
    return rgb


def test_frames_streamed_are_the_movie(tmp_path: Path) -> None:
    out = tmp_path / "m.mp4"
    stream = MovieStream(out, fps=10.0)
    for i in range(12):
        assert stream.add(_frame(i))
        assert not out.exists()  # written under the part's name until closed
    assert stream.close()
    assert out.is_file() and not stream.part_path.exists()
    frames, secs = imageio_ffmpeg.count_frames_and_secs(str(out))
    assert frames == 12 and secs == pytest.approx(1.2, abs=0.11)
    reader = imageio_ffmpeg.read_frames(str(out))
    assert next(reader)["size"] == (100, 50)  # H.264's even size: the odd edge cut off


def test_a_frame_it_cannot_take_ends_the_stream_cleanly(tmp_path: Path,
                                                         caplog: pytest.LogCaptureFixture
                                                         ) -> None:
    stream = MovieStream(tmp_path / "m.mp4")
    assert stream.add(_frame(0))
    with caplog.at_level(logging.ERROR):
        assert not stream.add(_frame(1, height=20, width=30))  # smaller than the movie
        assert not stream.add(_frame(2))  # failed for good
    assert sum("could not be added" in r.getMessage() for r in caplog.records) == 1
    assert not stream.close()
    assert not (tmp_path / "m.mp4").exists() and not stream.part_path.exists()


def test_make_movie_from_pngs_and_bad_names(tmp_path: Path) -> None:
    from PIL import Image

    pngs = []
    for i in range(5):
        pngs.append(tmp_path / f"frame_{i:09d}.png")
        Image.fromarray(_frame(i)).save(pngs[-1])
    make_movie(pngs, tmp_path / "m.mp4")
    assert imageio_ffmpeg.count_frames_and_secs(str(tmp_path / "m.mp4"))[0] == 5
    with pytest.raises(FsdError, match="must end in"):
        MovieStream(tmp_path / "m.gif")
    with pytest.raises(FsdError, match="no frames"):
        make_movie([], tmp_path / "n.mp4")
