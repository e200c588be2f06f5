"""``summary.json`` of a closed-loop simulation run (``orchestrator.sim``; every field:
docs/summary.md)."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

from mapper.evaluation import evaluate_map
from orchestrator.budget import budget_rows
from orchestrator.config import AppConfig
from orchestrator.main_loop import Main
from orchestrator.mission_result import mission_result
from simulator.clearance import run_clearance
from simulator.track import Track
from simulator.world import SimWorld

if TYPE_CHECKING:
    from orchestrator.sim import _Result, _SimRunner


def sim_summary(config: AppConfig, track: Track, world: SimWorld, main: Main,
                runner: _SimRunner, result: _Result, outputs_sha256: str) -> dict[str, Any]:
    """``summary.json`` of a finished run (docs/summary.md): ``runner`` the run (its driver,
    log and timer), ``result`` how it ended, ``outputs_sha256`` the hash of its outputs."""
    crossings = runner.person.autonomous_crossings_s
    lap_times = runner.person.lap_times_s()
    errors = runner.log.pose_errors()
    map_state = main.map_state
    map_eval: dict[str, Any] = {}
    if map_state is not None:
        map_eval = evaluate_map(map_state.cones, track.cones_xy_m, track.colours)
    stages_ms = main.times.summary_ms()
    tick_ms = stages_ms.get("tick", {})
    summary: dict[str, Any] = {
        "track": track.name,
        "seed": config.sim.seed,
        "mission": config.mission.mission,
        "exploration": config.mission.exploration,
        "mapper": config.mapper.backend,
        "finished": result.finished,
        "stop_reason": result.stop_reason,
        "laps_completed": len(crossings),
        "lap_times_s": lap_times,
        "best_lap_time_s": min(lap_times) if lap_times else None,
        "exploration_lap_time_s": _round(runner.person.exploration_lap_time_s),
        "handover_time_s": _round(runner.person.handover_time_s),
        "cones_hit": len(world.cones_hit),
        "cone_hits": [
            {"time_s": round(t, 3), "cone": int(i),
             "xy_m": [round(float(v), 3) for v in track.cones_xy_m[i]],
             "phase": "autonomous" if t >= runner.person.handover_time_s else "exploration"}
            for t, i in world.cone_hits],
        "off_track": world.off_track_events,
        "least_clearance": run_clearance(runner.log.t_s, runner.log.truth, track, config.car),
        "pose_rmse_m": _round(errors["pose_rmse_m"], 4),
        "heading_rmse_rad": _round(errors["heading_rmse_rad"], 5),
        "final_offset_m": _round(errors["final_offset_m"], 4),
        "map": map_eval,
        "nees": runner.log.nees(),
        "steering_while_exploring": runner.log.steering_while_exploring(),
        "loop_closure": {
            "closed": bool(map_state is not None and map_state.loop_closed),
            "time_s": _round(runner.loop_closure_time_s),
        },
        "timing": {
            "sim_time_s": round(result.sim_time_s, 3),
            "wall_time_s": round(result.wall_time_s, 3),
            "realtime_factor": round(result.sim_time_s / max(result.wall_time_s, 1e-9), 3),
            "control_period_target_ms": round(1e3 / config.run.control_rate_hz, 3),
            "control_period_p99_ms": round(1e3 / config.run.control_rate_hz, 3),
            "tick_wall_p99_ms": tick_ms.get("p99_ms"),
            "stages_ms": stages_ms,
            "budget": budget_rows(stages_ms, result.sim_time_s, result.wall_time_s),
            "lags_ms": main.lags_ms(),
        },
        "as_state": main.controller.state.name,
        "as_transitions": [
            {"time_s": round(t, 3), "from": a.name, "to": b.name, "reason": why}
            for t, a, b, why in main.controller.as_machine.transitions],
        "as_status_car": _as_status_car(world),
        "rejected_stale": dict(main.rejected),
        "outputs_sha256": outputs_sha256,
    }
    mission_time = (result.sim_time_s - runner.person.handover_time_s
                    if result.finished else None)
    view = getattr(main.planner, "explored_view", lambda: None)()
    summary["mission_result"] = mission_result(config.mission.mission, track, config.car,
                                               runner.timer, mission_time,
                                               runner.person.exploration_lap_time_s, view)
    if runner.estop is not None:
        summary["estop"] = runner.estop
    return summary


def _as_status_car(world: SimWorld) -> dict[str, Any]:
    """``AS_STATUS`` as the simulated car decoded it: frames, the last status, every change."""
    last = world.as_status
    return {
        "frames": world.as_status_frames,
        "state": last.state.name if last is not None else None,
        "mission": last.mission.name if last is not None else None,
        "lap": last.lap if last is not None else None,
        "assi": last.assi.name if last is not None else None,
        "transitions": [{"time_s": round(t, 3), "state": state.name}
                        for t, state in world.as_transitions],
    }


def _round(value: float, digits: int = 3) -> float | None:
    return None if value is None or not math.isfinite(value) else round(value, digits)
