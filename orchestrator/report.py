"""``report.html`` of a run folder: one file to share, opened in a browser with no server.

The summary table (the headline figures the CLI prints), the plots (``trajectory.png``,
``position_error.png``, ``speed.png``) and a few frames embedded as data URIs, the movie and the
full ``summary.json`` linked and shown. Only what exists in the folder is included.
"""

from __future__ import annotations

import base64
import html
import io
import json
import logging
from pathlib import Path
from typing import Any

from orchestrator.summary_table import summary_rows

log = logging.getLogger(__name__)

REPORT_NAME = "report.html"
PLOTS = (("trajectory.png", "Trajectory: estimate, truth and cones"),
         ("speed.png", "Speed against the plan's target"),
         ("position_error.png", "Pose error against the truth"))
FRAMES_SHOWN = 4
FRAME_WIDTH_PX = 640

_STYLE = """
body { font-family: system-ui, sans-serif; margin: 2em auto; max-width: 1300px; color: #222; }
h1 { font-size: 1.5em; } h2 { font-size: 1.2em; margin-top: 1.6em; }
table { border-collapse: collapse; } td { padding: 2px 12px 2px 0; vertical-align: top; }
td.k { color: #666; white-space: nowrap; }
.grid { display: flex; flex-wrap: wrap; gap: 12px; }
figure { margin: 0; } figcaption { font-size: 0.85em; color: #555; }
img { max-width: 100%; border: 1px solid #ccc; } pre { background: #f5f5f5; padding: 1em; }
"""


def _data_uri(data: bytes, mime: str) -> str:
    return f"data:{mime};base64,{base64.b64encode(data).decode('ascii')}"


def _frame_uri(path: Path) -> str:
    """A frame scaled to :data:`FRAME_WIDTH_PX` wide, as a JPEG data URI (small to embed)."""
    from PIL import Image

    with Image.open(path) as image:
        rgb = image.convert("RGB")
        if rgb.width > FRAME_WIDTH_PX:
            rgb = rgb.resize((FRAME_WIDTH_PX, round(rgb.height * FRAME_WIDTH_PX / rgb.width)))
        buffer = io.BytesIO()
        rgb.save(buffer, format="JPEG", quality=85)
    return _data_uri(buffer.getvalue(), "image/jpeg")


def pick_frames(frames: list[Path], count: int = FRAMES_SHOWN) -> list[Path]:
    """``count`` frames spread evenly over the run, the last one included."""
    if len(frames) <= count:
        return list(frames)
    step = (len(frames) - 1) / (count - 1)
    return [frames[round(i * step)] for i in range(count)]


def write_report(out_dir: Path, summary: dict[str, Any], title: str = "Run") -> Path:
    """Write ``out_dir/report.html`` for ``summary`` and what ``out_dir`` holds; returns it."""
    e = html.escape
    parts = [f"<!doctype html><html><head><meta charset='utf-8'><title>{e(title)}: "
             f"{e(str(summary.get('track', out_dir.name)))}</title><style>{_STYLE}</style>"
             f"</head><body><h1>{e(title)} {e(out_dir.name)}</h1>"]
    parts.append("<h2>Summary</h2><table>")
    rows = summary_rows(summary)
    if "recording" in summary:  # a replay: what was replayed
        rows.insert(0, ("recording", str(summary["recording"])))
    for name, value in rows:
        if value.strip(" -/") == "":
            continue  # not measured in this kind of run (a replay has no lap times)
        parts.append(f"<tr><td class='k'>{e(name)}</td><td>{e(value)}</td></tr>")
    parts.append("</table>")

    plots = [(out_dir / name, caption) for name, caption in PLOTS if (out_dir / name).exists()]
    if plots:
        parts.append("<h2>Plots</h2><div class='grid'>")
        for path, caption in plots:
            uri = _data_uri(path.read_bytes(), "image/png")
            parts.append(f"<figure><img src='{uri}' width='620' alt='{e(path.name)}'>"
                         f"<figcaption>{e(caption)} ({e(path.name)})</figcaption></figure>")
        parts.append("</div>")

    frames = sorted((out_dir / "frames").glob("frame_*.png"))
    if frames:
        parts.append(f"<h2>Frames</h2><p>{len(frames)} frames in "
                     f"<a href='frames/'>frames/</a>; {min(len(frames), FRAMES_SHOWN)} shown "
                     "(each has its legend, the AS state and the laps).</p><div class='grid'>")
        for path in pick_frames(frames):
            t_s = int(path.stem.removeprefix("frame_")) / 1000.0
            try:
                uri = _frame_uri(path)
            except OSError as exc:  # a frame still being written, or damaged: skip it
                log.warning("report: frame %s left out: %s", path, exc)
                continue
            parts.append(f"<figure><a href='frames/{e(path.name)}'><img src='{uri}' "
                         f"width='{FRAME_WIDTH_PX}' alt='{e(path.name)}'></a>"
                         f"<figcaption>t = {t_s:.1f} s</figcaption></figure>")
        parts.append("</div>")

    movies = [p for p in (out_dir / "movie.mp4", out_dir / "movie.gif") if p.exists()]
    for movie in movies:
        parts.append(f"<h2>Movie</h2><p><a href='{e(movie.name)}'>{e(movie.name)}</a></p>")
        if movie.suffix == ".mp4":
            parts.append(f"<video controls width='960' src='{e(movie.name)}'></video>")
        else:
            parts.append(f"<img src='{e(movie.name)}' width='960' alt='movie'>")

    if (out_dir / "recording.mcap").exists():
        parts.append("<h2>Recording</h2><p><a href='recording.mcap'>recording.mcap</a>: opens "
                     "in Foxglove with the layout shipped in "
                     "<code>recordings/foxglove/layout.json</code>.</p>")
    parts.append("<h2>summary.json</h2><details><summary>all keys</summary><pre>"
                 f"{e(json.dumps(summary, indent=2))}</pre></details></body></html>\n")
    target = out_dir / REPORT_NAME
    target.write_text("".join(parts), encoding="utf-8")
    return target
