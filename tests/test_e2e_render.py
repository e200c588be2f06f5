"""End to end: a ``sim --render`` run writes frames and a movie (streamed as the frames are drawn,
issue 42); ``render`` of its recording writes frames of the asked size and a movie when asked
(issue 8), all through ``main.py``. The movie streams themselves: ``test_movie_stream``."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import imageio_ffmpeg
import pytest
from PIL import Image

ROOT = Path(__file__).resolve().parents[1]


def main_py(*args: str, timeout_s: float = 180.0) -> subprocess.CompletedProcess[str]:
    env = dict(os.environ, SDL_VIDEODRIVER="dummy", MPLBACKEND="Agg")
    return subprocess.run([sys.executable, "main.py", *args], cwd=ROOT, env=env,
                          capture_output=True, text=True, timeout=timeout_s, check=False)


@pytest.mark.slow
def test_sim_render_and_render_command(tmp_path: Path) -> None:
    config = tmp_path / "short.toml"
    config.write_text("[run]\nmax_sim_time_s = 12.0\n[visualiser]\nwidth_px = 480\n"
                      "height_px = 270\nfps = 2.0\nmovie = \"movie.mp4\"\n")
    run = tmp_path / "run"
    proc = main_py("sim", "--config", str(config), "--render", "--out", str(run))
    assert proc.returncode in (0, 1), proc.stderr  # 1: stopped at max_sim_time_s (expected)
    summary = json.loads((run / "summary.json").read_text())
    frames = sorted((run / "frames").glob("frame_*.png"))
    assert frames and summary["frames"]["rendered"] == len(frames)
    assert len(frames) + summary["frames"]["dropped"] >= 20  # 2 fps over 12 s: 24 submitted
    assert Image.open(frames[0]).size == (480, 270)
    # the movie was streamed while the frames were drawn: one movie frame per PNG, none lost
    assert imageio_ffmpeg.count_frames_and_secs(str(run / "movie.mp4"))[0] == len(frames)
    assert not (run / "movie.mp4.part").exists()
    for plot in ("trajectory.png", "position_error.png", "speed.png"):
        assert (run / plot).stat().st_size > 0

    out = tmp_path / "rendered"
    proc = main_py("render", str(run / "recording.mcap"), "--out", str(out), "--size", "320x200",
                   "--fps", "2", "--movie", str(out / "m.gif"))
    assert proc.returncode == 0, proc.stderr
    rendered = sorted(out.glob("frame_*.png"))
    # Map states are recorded at 10 Hz; --fps 2 keeps one every 0.5 s of the 12 s run.
    assert 20 <= len(rendered) <= 26
    assert all(Image.open(p).size == (320, 200) for p in rendered[:3])
    assert getattr(Image.open(out / "m.gif"), "n_frames", 0) == len(rendered)
    # Frames are named by their time (ms): 0.5 s apart.
    times_ms = [int(p.stem.split("_")[1]) for p in rendered]
    assert all(b - a == 500 for a, b in zip(times_ms, times_ms[1:], strict=False))

    proc = main_py("render", str(tmp_path / "absent.mcap"), "--out", str(out))
    assert proc.returncode != 0 and "absent.mcap" in proc.stderr
    assert "Traceback" not in proc.stderr
