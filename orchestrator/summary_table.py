"""A short human-readable table of a run's summary (the CLI prints it)."""

from __future__ import annotations

from typing import Any


def _fmt(value: Any) -> str:
    if value is None:
        return "-"
    if isinstance(value, float):
        return f"{value:.3f}"
    if isinstance(value, list):
        return ", ".join(_fmt(v) for v in value) or "-"
    return str(value)


def format_summary(summary: dict[str, Any]) -> str:
    """The headline figures of ``summary.json``, one per line."""
    rows = summary_rows(summary)
    width = max(len(name) for name, _ in rows)
    return "\n".join(f"{name:<{width}}  {value}" for name, value in rows)


def summary_rows(summary: dict[str, Any]) -> list[tuple[str, str]]:
    """The headline figures of ``summary.json`` as (name, formatted value) rows."""
    timing = summary.get("timing", {})
    map_eval = summary.get("map", {})
    rows = [
        ("track", summary.get("track")),
        ("finished", summary.get("finished")),
        ("stop reason", summary.get("stop_reason")),
        ("autonomous laps", summary.get("laps_completed")),
        ("lap times (s)", summary.get("lap_times_s")),
        ("exploration lap (s)", summary.get("exploration_lap_time_s")),
        ("cones hit", summary.get("cones_hit")),
        ("off track", summary.get("off_track")),
        ("pose RMSE (m)", summary.get("pose_rmse_m")),
        ("heading RMSE (rad)", summary.get("heading_rmse_rad")),
        ("map landmarks / true", f"{map_eval.get('landmarks', '-')} / "
                                 f"{map_eval.get('true_cones', '-')}"),
        ("map RMSE (m)", map_eval.get("rmse_m")),
        ("loop closed at (s)", summary.get("loop_closure", {}).get("time_s")),
        ("sim / wall time (s)", f"{_fmt(timing.get('sim_time_s'))} / "
                                f"{_fmt(timing.get('wall_time_s'))}"),
        ("realtime factor", timing.get("realtime_factor")),
    ]
    least = summary.get("least_clearance") or {}
    if least.get("gap_m") is not None:
        after_off_track = [name for name, _ in rows].index("off track") + 1
        rows.insert(after_off_track, ("least clearance (m)", f"{least['gap_m']:.3f} (cone "
                                      f"{least['cone']} at {least['time_s']:.2f} s)"))
    result = summary.get("mission_result") or {}
    explored_rows: list[tuple[str, Any]] = []
    if result.get("explored_ratio") is not None:
        explored_rows.append(("explored / friction limit", result["explored_ratio"]))
    if result.get("explored_standing_ratio") is not None:
        explored_rows.append(("explored / standing start", result["explored_standing_ratio"]))
    rows[6:6] = explored_rows
    if result.get("view_ceiling_ratio") is not None:
        rows.insert(6 + len(explored_rows), (
            "in view while exploring", f"{result['explored_view_m']:.1f} m: at most "
                                       f"{result['view_speed_mps']:.1f} m/s, "
                                       f"{result['view_ceiling_ratio']:.2f}x at best"))
    steering = summary.get("steering_while_exploring") or {}
    if steering.get("seconds"):
        rows.append(("steering rate exploring", f"{steering['rate_rms_radps']:.3f} rad/s RMS "
                                                f"over {steering['seconds']:.1f} s"))
    if "estop" in summary:
        estop = summary["estop"]
        rows.append(("e-stop distance (m)", f"{_fmt(estop.get('stop_distance_m'))} "
                                            f"(allowed {_fmt(estop.get('allowed_distance_m'))})"))
    if "live" in summary:
        live = summary["live"]
        rows.append(("live view", f"{live.get('address')}: {live.get('clients_max')} client(s) "
                                  f"at most, {live.get('messages_sent')} sent, "
                                  f"{live.get('messages_dropped')} dropped"))
    if "out_dir" in summary:
        rows.append(("run folder", summary["out_dir"]))
    return [(name, _fmt(value)) for name, value in rows]
