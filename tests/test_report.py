"""``report.html``: the summary table, the plots and a few frames embedded, the movie linked;
only what the run folder holds."""

from __future__ import annotations

import re
from pathlib import Path

from PIL import Image

from orchestrator.report import pick_frames, write_report

SUMMARY = {"track": "default", "finished": True, "stop_reason": "finished: 2 laps",
           "laps_completed": 2, "lap_times_s": [22.86, 22.414], "cones_hit": 0,
           "timing": {"sim_time_s": 94.4, "wall_time_s": 23.1, "realtime_factor": 4.09}}


def _png(path: Path, colour: tuple[int, int, int], size: tuple[int, int] = (1280, 720)) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    Image.new("RGB", size, colour).save(path)


def test_pick_frames_spreads_and_keeps_the_last() -> None:
    frames = [Path(f"frame_{i:09d}.png") for i in range(10)]
    assert pick_frames(frames, 4) == [frames[0], frames[3], frames[6], frames[9]]
    assert pick_frames(frames[:2], 4) == frames[:2]


def test_report_of_a_full_run_folder(tmp_path: Path) -> None:
    _png(tmp_path / "speed.png", (0, 0, 255), (800, 400))
    _png(tmp_path / "trajectory.png", (0, 255, 0), (800, 400))
    for k in range(9):
        _png(tmp_path / "frames" / f"frame_{k * 500:09d}.png", (20 * k, 0, 0))
    (tmp_path / "movie.mp4").write_bytes(b"\x00")
    html = write_report(tmp_path, SUMMARY, "sim").read_text()
    assert "<td>22.860, 22.414</td>" in html and "finished: 2 laps" in html
    assert len(re.findall(r"src='data:image/png;base64,", html)) == 2  # the two plots
    assert len(re.findall(r"src='data:image/jpeg;base64,", html)) == 4  # four frames
    assert "frames/frame_000004000.png" in html  # the last frame is one of them
    assert "t = 4.0 s" in html
    assert "<video controls width='960' src='movie.mp4'>" in html
    assert "position_error.png" not in html  # not in the folder, not in the report
    assert "pose RMSE" not in html  # not measured: no row


def test_report_without_frames_or_plots(tmp_path: Path) -> None:
    html = write_report(tmp_path, {"recording": "a.mcap", "stop_reason": "timeout"},
                        "replay").read_text()
    assert "timeout" in html and "<td>a.mcap</td>" in html
    assert "data:image" not in html and "<video" not in html and "Frames" not in html
