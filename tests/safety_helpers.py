"""The safety supervisor's test fixtures: a straight plan, a pose, sensor health, and a
controller driving on them (shared by the supervisor's and the planner's late-plan tests)."""

from __future__ import annotations

import numpy as np

from common.messages import (
    AsState,
    Baseframe,
    Health,
    Plan,
    PoseEstimate,
    RemoteStop,
    SourceHealth,
    TargetStates,
)
from controller.controller import Controller
from orchestrator.config import AppConfig
from planner.baseframe import SplineBaseframe
from planner.path_planner import PathPlanner


def straight_plan(t: float, lap: int = 0, speed: float = 10.0) -> Plan:
    x = np.arange(0.0, 300.0, 0.5)
    z = np.zeros_like(x)
    targets = TargetStates(t + x / speed, x, z, z, np.full_like(x, speed), z)
    frame = Baseframe(x, x, z, z, z, closed=False, length_m=300.0)
    return Plan(t, frame, targets, speed, lap=lap, chosen_index=0)


def pose(t: float, x: float = 10.0, y: float = 0.0, v: float = 10.0,
         sigma: float = 0.05) -> PoseEstimate:
    cov = np.diag([sigma**2, sigma**2, 0.01**2])
    return PoseEstimate(t, x, y, 0.0, v, 0.0, 0.0, cov)


def health(t: float, stale: tuple[str, ...] = ()) -> Health:
    sources = tuple(SourceHealth(t, name, True, 10.0, 0.01, 0, name in stale)
                    for name in ("gps", "imu", "lidar", "camera"))
    return Health(t, sources)


def driving_controller(config: AppConfig | None = None) -> Controller:
    config = config or AppConfig()
    ctrl = Controller(config.controller, config.car, laps=3)
    assert ctrl.state == AsState.OFF
    ctrl.command(0.0, pose(0.0), straight_plan(0.0), health(0.0), None)
    assert ctrl.state == AsState.READY  # auto-armed by the first plan with a baseframe
    cmd = ctrl.command(0.01, pose(0.01), straight_plan(0.01), health(0.01), None)
    assert cmd.brake > 0.0  # brakes held in READY
    ctrl.command(0.02, pose(0.02), straight_plan(0.02), health(0.02),
                 RemoteStop(0.02, False, True))
    assert ctrl.state == AsState.DRIVING
    return ctrl


def straight_manoeuvre_plan(planner: PathPlanner, x_m: float, speed_mps: float,
                            path_speed_mps: float, t_s: float, length_m: float) -> Plan:
    """The planner's chosen manoeuvre from (``x_m``, 0) heading +x at ``speed_mps`` along a
    straight of ``length_m`` from x = 0 with no cones, asking ``path_speed_mps`` all along, as
    the Plan it sends at ``t_s``."""
    x = np.arange(0.0, length_m, 2.0)
    frame = SplineBaseframe(np.column_stack([x, np.zeros_like(x)]), closed=False)
    cands, best = planner.generator.generate(frame, x_m, 0.0, 0.0, speed_mps, np.zeros((0, 2)),
                                             None)
    assert best >= 0
    chosen = cands[best]
    n = len(chosen.xy_m)
    targets = TargetStates(np.full(n, t_s), chosen.xy_m[:, 0], chosen.xy_m[:, 1],
                           chosen.heading_rad, np.full(n, path_speed_mps),
                           chosen.curvature_1pm)
    z = np.zeros_like(x)
    baseframe = Baseframe(x, x, z, z, z, closed=False, length_m=length_m)
    return Plan(t_s, baseframe, targets, path_speed_mps, chosen_index=0)
