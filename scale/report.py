"""``report.html`` of a campaign: the spread per track and the worst runs.

Per track: runs, failures, the best lap's spread (min, median, max, standard deviation, s),
cones hit, off-track events, pose and map RMSE (median and worst, m); box plots of the best
laps and the pose RMSE (one PNG embedded in the page); then the worst runs (failed first, then
most cones hit and off-track events, then the slowest best lap against its track's median), each
linked to its summary (``runs/<run_id>.json``) with the command that runs it alone.
"""

from __future__ import annotations

import base64
import html
import io
import math
import shlex
import statistics
from collections.abc import Sequence
from pathlib import Path
from typing import Any

WORST_RUNS = 12
"""How many runs the worst-runs table lists."""


def _float(value: Any) -> float:
    try:
        return float(value)
    except (TypeError, ValueError):
        return math.nan


def _int(value: Any) -> int:
    try:
        return int(float(value))
    except (TypeError, ValueError):
        return 0


def _finite(values: Sequence[float]) -> list[float]:
    return [v for v in values if math.isfinite(v)]


def _fmt(value: float, digits: int = 3) -> str:
    return "-" if not math.isfinite(value) else f"{value:.{digits}f}"


def track_stats(rows: Sequence[dict[str, Any]]) -> dict[str, dict[str, float]]:
    """Per track: ``runs``, ``failed``, ``lap_min_s``, ``lap_median_s``, ``lap_max_s``,
    ``lap_std_s``, ``cones_hit``, ``off_track``, ``pose_rmse_median_m``, ``pose_rmse_max_m``,
    ``map_rmse_median_m``, ``map_rmse_max_m`` (NaN where no run gives the figure)."""
    stats: dict[str, dict[str, float]] = {}
    for track in sorted({str(r["track"]) for r in rows}):
        mine = [r for r in rows if r["track"] == track]
        laps = _finite([_float(r["best_lap_time_s"]) for r in mine])
        pose = _finite([_float(r["pose_rmse_m"]) for r in mine])
        maps = _finite([_float(r["map_rmse_m"]) for r in mine])
        stats[track] = {
            "runs": len(mine),
            "failed": sum(1 for r in mine if r["error"]),
            "lap_min_s": min(laps, default=math.nan),
            "lap_median_s": statistics.median(laps) if laps else math.nan,
            "lap_max_s": max(laps, default=math.nan),
            "lap_std_s": statistics.stdev(laps) if len(laps) > 1 else math.nan,
            "cones_hit": sum(_int(r["cones_hit"]) for r in mine),
            "off_track": sum(_int(r["off_track"]) for r in mine),
            "pose_rmse_median_m": statistics.median(pose) if pose else math.nan,
            "pose_rmse_max_m": max(pose, default=math.nan),
            "map_rmse_median_m": statistics.median(maps) if maps else math.nan,
            "map_rmse_max_m": max(maps, default=math.nan),
        }
    return stats


def worst_runs(rows: Sequence[dict[str, Any]], count: int = WORST_RUNS) -> list[dict[str, Any]]:
    """The ``count`` worst runs: failed, then cones hit + off-track, then not finished, then the
    best lap's ratio to its track's median."""
    stats = track_stats(rows)

    def badness(r: dict[str, Any]) -> tuple[int, int, int, float]:
        median = stats[str(r["track"])]["lap_median_s"]
        lap = _float(r["best_lap_time_s"])
        ratio = lap / median if math.isfinite(lap) and median > 0 else math.inf
        finished = str(r["finished"]).lower() == "true"
        return (1 if r["error"] else 0, _int(r["cones_hit"]) + _int(r["off_track"]),
                0 if finished else 1, ratio)

    return sorted(rows, key=badness, reverse=True)[:count]


def command_of(row: dict[str, Any]) -> str:
    """The ``sim`` command running this row's run alone (its setting, if any, goes in a
    ``--config`` file)."""
    parts = ["python", "main.py", "sim", "--track", str(row["track"]), "--seed",
             str(row["seed"]), "--laps", str(row["laps"]), "--no-render", "--no-record"]
    if row.get("mission"):
        parts += ["--mission", str(row["mission"])]
    if row.get("fault") and row["fault"] != "none":
        for fault in str(row["fault"]).split("+"):
            parts += ["--fault", fault]
    return shlex.join(parts)


def _plot_png(rows: Sequence[dict[str, Any]]) -> str:
    """Box plots of best laps and pose RMSE per track, as base64 PNG ('' when nothing to plot)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    tracks = sorted({str(r["track"]) for r in rows})
    laps = [_finite([_float(r["best_lap_time_s"]) for r in rows if r["track"] == t])
            for t in tracks]
    pose = [_finite([_float(r["pose_rmse_m"]) for r in rows if r["track"] == t]) for t in tracks]
    if not any(laps) and not any(pose):
        return ""
    names = [Path(t).stem if "/" in t else t for t in tracks]
    fig, axes = plt.subplots(1, 2, figsize=(max(8.0, 1.2 * len(tracks) + 4.0), 4.5))
    for ax, data, label in ((axes[0], laps, "best lap (s)"), (axes[1], pose, "pose RMSE (m)")):
        ax.boxplot([d if d else [math.nan] for d in data])
        ax.set_xticks(range(1, len(names) + 1), names, rotation=30, ha="right")
        ax.set_ylabel(label)
        ax.grid(True, axis="y", alpha=0.3)
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=90)
    plt.close(fig)
    return base64.b64encode(buf.getvalue()).decode()


def render_html(rows: Sequence[dict[str, Any]], meta: dict[str, Any]) -> str:
    """The report page."""
    esc = html.escape
    stats = track_stats(rows)
    engine = meta.get("engine", {})
    out = ["<!doctype html><html><head><meta charset='utf-8'><title>campaign report</title>",
           "<style>body{font-family:sans-serif;margin:1.5em}table{border-collapse:collapse}"
           "td,th{border:1px solid #bbb;padding:3px 7px;text-align:right}"
           "td.l,th.l{text-align:left}code{font-size:90%}</style></head><body>",
           "<h1>Campaign report</h1>",
           f"<p>{len(rows)} runs, {sum(1 for r in rows if r['error'])} failed; engine "
           f"{esc(str(engine.get('engine', '?')))} {esc(str(engine.get('version', '')))} at "
           f"{esc(str(engine.get('address', '')))} ({engine.get('nodes', '?')} node(s), "
           f"{engine.get('cpus', '?')} CPUs); wall time {meta.get('wall_s', '?')} s.</p>",
           "<h2>Per track</h2><table><tr><th class=l>track</th><th>runs</th><th>failed</th>"
           "<th>best lap min</th><th>median</th><th>max</th><th>std</th><th>cones hit</th>"
           "<th>off track</th><th>pose RMSE median</th><th>worst</th><th>map RMSE median</th>"
           "<th>worst</th></tr>"]
    for track, s in stats.items():
        out.append(
            f"<tr><td class=l>{esc(track)}</td><td>{s['runs']:.0f}</td><td>{s['failed']:.0f}</td>"
            f"<td>{_fmt(s['lap_min_s'])}</td><td>{_fmt(s['lap_median_s'])}</td>"
            f"<td>{_fmt(s['lap_max_s'])}</td><td>{_fmt(s['lap_std_s'])}</td>"
            f"<td>{s['cones_hit']:.0f}</td><td>{s['off_track']:.0f}</td>"
            f"<td>{_fmt(s['pose_rmse_median_m'])}</td><td>{_fmt(s['pose_rmse_max_m'])}</td>"
            f"<td>{_fmt(s['map_rmse_median_m'])}</td><td>{_fmt(s['map_rmse_max_m'])}</td></tr>")
    out.append("</table><p>Lap times in s, RMSE in m.</p>")
    png = _plot_png(rows)
    if png:
        out.append(f"<img alt='spread per track' src='data:image/png;base64,{png}'>")
    out.append("<h2>Worst runs</h2><table><tr><th class=l>run</th><th class=l>track</th>"
               "<th>seed</th><th class=l>fault</th><th class=l>setting</th><th>best lap</th>"
               "<th>cones</th><th>off</th><th>pose RMSE</th><th class=l>stop / error</th>"
               "<th class=l>alone</th></tr>")
    for r in worst_runs(rows):
        link = (f"<a href='runs/{esc(str(r['run_id']))}.json'>{esc(str(r['run_id']))}</a>"
                if not r["error"] else esc(str(r["run_id"])))
        out.append(
            f"<tr><td class=l>{link}</td><td class=l>{esc(str(r['track']))}</td>"
            f"<td>{esc(str(r['seed']))}</td><td class=l>{esc(str(r['fault']))}</td>"
            f"<td class=l>{esc(str(r['setting']))}</td>"
            f"<td>{_fmt(_float(r['best_lap_time_s']))}</td><td>{_int(r['cones_hit'])}</td>"
            f"<td>{_int(r['off_track'])}</td><td>{_fmt(_float(r['pose_rmse_m']))}</td>"
            f"<td class=l>{esc(str(r['error'] or r['stop_reason']))}</td>"
            f"<td class=l><code>{esc(command_of(r))}</code></td></tr>")
    out.append("</table></body></html>\n")
    return "\n".join(out)


def write_report(path: Path, rows: Sequence[dict[str, Any]], meta: dict[str, Any]) -> None:
    """Write ``report.html`` for these rows."""
    path.write_text(render_html(rows, meta))
