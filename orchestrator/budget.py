"""Where a run's wall time goes, per simulated second (issue 42's budget table).

Main's :class:`~orchestrator.main_loop.StageTimes` and the sim runner time every stage of every
tick. :func:`budget_rows` turns those totals into milliseconds of wall time per simulated
second, so that a team sees at once which stage keeps its loop from a real-time factor: at 10x
real time the whole loop has 100 ms per simulated second. ``sim --profile`` and ``bench sim``
print :func:`format_budget`; ``summary.json`` keeps the rows under ``timing.budget``.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

BUDGET_STAGES: tuple[tuple[str, tuple[str, ...], str], ...] = (
    ("simulator", ("simulator",), "vehicle, sensor models, scoring"),
    ("sensors", ("sensors", "health"), "decoding raw bytes, cone detection, health"),
    ("mapper", ("mapper",), "localisation, SLAM"),
    ("planner", ("planner",), "path and speed plan"),
    ("controller", ("controller",), "control, safety, AS state"),
    ("outputs", ("outputs", "truth_out"), "hash, hand-over to the recorder, live view"),
    ("run", ("run",), "the run's own bookkeeping: scoring laps, log, progress"),
)
"""(row, stages of :class:`StageTimes` summed into it, what it covers)."""

TARGET_FACTOR = 10.0
"""The real-time factor the table is read against (issue 42): 100 ms per simulated second."""


def budget_rows(stages_ms: Mapping[str, Mapping[str, float]], sim_time_s: float,
                wall_time_s: float) -> list[dict[str, Any]]:
    """One row per stage of :data:`BUDGET_STAGES` (stages that never ran are left out), then
    ``other`` (the wall time no stage accounts for) and ``total``: ``ms_per_s`` (wall
    milliseconds per simulated second), ``share`` of the wall time, ``calls`` and ``mean_ms``."""
    sim_s = max(sim_time_s, 1e-9)
    wall_s = max(wall_time_s, 1e-9)
    rows: list[dict[str, Any]] = []
    counted = 0.0
    for name, keys, what in BUDGET_STAGES:
        present = [stages_ms[k] for k in keys if k in stages_ms]
        if not present:
            continue
        total_s = sum(float(s["total_s"]) for s in present)
        calls = int(present[0]["count"])
        counted += total_s
        rows.append(_row(name, what, total_s, sim_s, wall_s, calls))
    rows.append(_row("other", "between the stages", max(wall_s - counted, 0.0), sim_s, wall_s,
                     None))
    rows.append(_row("total", f"real-time factor {sim_s / wall_s:.2f}", wall_s, sim_s, wall_s,
                     None))
    return rows


def _row(name: str, what: str, total_s: float, sim_s: float, wall_s: float,
         calls: int | None) -> dict[str, Any]:
    return {"stage": name, "what": what, "ms_per_s": round(1e3 * total_s / sim_s, 3),
            "share": round(total_s / wall_s, 4), "total_s": round(total_s, 3), "calls": calls,
            "mean_ms": round(1e3 * total_s / calls, 4) if calls else None}


def format_budget(rows: list[dict[str, Any]], sim_time_s: float, wall_time_s: float) -> str:
    """The budget table as text, then the real-time factor against :data:`TARGET_FACTOR`."""
    budget = 1e3 / TARGET_FACTOR
    lines = [f"{'stage':<11} {'ms/sim s':>9} {'share':>6} {'calls':>7} {'ms/call':>8}  what",
             "-" * 78]
    for row in rows:
        calls = "" if row["calls"] is None else str(row["calls"])
        mean = "" if row["mean_ms"] is None else f"{row['mean_ms']:.3f}"
        if row["stage"] == "total":
            lines.append("-" * 78)
        lines.append(f"{row['stage']:<11} {row['ms_per_s']:9.1f} {100 * row['share']:5.1f}% "
                     f"{calls:>7} {mean:>8}  {row['what']}")
    factor = sim_time_s / max(wall_time_s, 1e-9)
    lines.append(f"real-time factor {factor:.2f} ({sim_time_s:.1f} simulated s in "
                 f"{wall_time_s:.2f} wall s); {TARGET_FACTOR:.0f}x leaves {budget:.0f} ms per "
                 "simulated second")
    return "\n".join(lines)
