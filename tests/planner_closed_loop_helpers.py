"""A small kinematic bicycle and a closed loop (planner + controller, perfect pose) for tests.

Not a test module itself (no ``test_`` prefix); imported by tests/test_planner_closed_loop.py
and the planner's other tests.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from common.messages import (
    ActuatorCommand,
    AsState,
    ConeMap,
    Health,
    MapState,
    Plan,
    PoseEstimate,
    RemoteStop,
)
from controller.controller import Controller
from orchestrator.config import AppConfig
from planner.manoeuvres import ManoeuvreGenerator
from planner.path_planner import PathPlanner


@dataclass
class Bicycle:
    """Kinematic bicycle about the rear axle with steering lag and rate limit, drag, and the
    car's drive and brake limits. ``lateral_accel_max_mps2`` records the largest v^2 kappa."""

    wheelbase_m: float
    max_drive_mps2: float
    max_brake_mps2: float
    max_steer_rad: float
    max_steer_rate_radps: float
    steer_lag_s: float
    x_m: float = 0.0
    y_m: float = 0.0
    yaw_rad: float = 0.0
    v_mps: float = 0.0
    steer_rad: float = 0.0
    lateral_peak_mps2: float = 0.0
    drag_per_v2: float = 0.0015
    history: list[tuple[float, float]] = field(default_factory=list)

    def step(self, cmd: ActuatorCommand, dt: float) -> None:
        target = max(min(cmd.steering_rad, self.max_steer_rad), -self.max_steer_rad)
        rate = (target - self.steer_rad) / max(self.steer_lag_s, dt)
        rate = max(min(rate, self.max_steer_rate_radps), -self.max_steer_rate_radps)
        self.steer_rad += rate * dt
        accel = cmd.throttle * self.max_drive_mps2 - self.drag_per_v2 * self.v_mps**2
        if self.v_mps > 0.0:
            accel -= cmd.brake * self.max_brake_mps2
        self.v_mps = max(self.v_mps + accel * dt, 0.0)
        kappa = math.tan(self.steer_rad) / self.wheelbase_m
        self.lateral_peak_mps2 = max(self.lateral_peak_mps2, self.v_mps**2 * abs(kappa))
        self.yaw_rad = math.remainder(self.yaw_rad + self.v_mps * kappa * dt, 2.0 * math.pi)
        self.x_m += self.v_mps * math.cos(self.yaw_rad) * dt
        self.y_m += self.v_mps * math.sin(self.yaw_rad) * dt

    def footprint(self, length_m: float, width_m: float, rear_m: float) -> np.ndarray:
        c, s = math.cos(self.yaw_rad), math.sin(self.yaw_rad)
        local = np.array([[-rear_m, -width_m / 2], [length_m - rear_m, -width_m / 2],
                          [length_m - rear_m, width_m / 2], [-rear_m, width_m / 2]])
        return np.stack([self.x_m + local[:, 0] * c - local[:, 1] * s,
                         self.y_m + local[:, 0] * s + local[:, 1] * c], axis=1)


def bicycle_for(config: AppConfig) -> Bicycle:
    car = config.car
    return Bicycle(car.wheelbase_m, car.max_drive_accel_mps2, car.max_brake_decel_mps2,
                   car.max_steer_rad, car.max_steer_rate_radps, car.steer_lag_s)


def cone_map(xy: np.ndarray, colours: np.ndarray) -> ConeMap:
    n = len(xy)
    return ConeMap(xy_m=xy, covariance=np.tile(np.eye(2) * 0.01, (n, 1, 1)),
                   colour=colours.astype(np.int64), size=np.ones(n, np.int64),
                   confidence=np.ones(n), ids=np.arange(n))


@dataclass
class LoopResult:
    lap_times_s: list[float]
    cones_hit: set[int]
    off_track: int
    max_offset_m: float
    max_frame_offset_m: float
    """Largest distance (m) of the rear axle from the planner's baseframe (tracking error)."""
    max_plan_error_m: float
    """Largest cross-track error (m) of the rear axle from the manoeuvre being followed."""
    final_state: AsState
    stop_reason: str
    lateral_peak_mps2: float
    time_s: float
    trace: np.ndarray = field(default_factory=lambda: np.zeros((0, 7)))
    """Every 0.1 s while driving (K, 7): time (s), arc length on the baseframe (m), its
    curvature there (1/m), the steering command (rad), speed (m/s), the id of the baseframe
    object (a rebuilt baseframe has a new one) and its length (m)."""


class DynamicAdapter:
    """simulator.vehicle.Vehicle behind the Bicycle's interface (x_m, y_m, yaw_rad, v_mps)."""

    def __init__(self, config: AppConfig) -> None:
        from simulator.vehicle import Vehicle

        self.vehicle = Vehicle(config.car)
        self.lateral_peak_mps2 = 0.0

    def __getattr__(self, name: str) -> float:
        st = self.__dict__["vehicle"].state
        return {"x_m": st.x_m, "y_m": st.y_m, "yaw_rad": st.yaw_rad, "v_mps": st.vx_mps,
                "vy_mps": st.vy_mps, "yaw_rate": st.yaw_rate_radps}[name]

    def step(self, cmd: ActuatorCommand, dt: float) -> None:
        self.vehicle.step(cmd, dt)
        self.lateral_peak_mps2 = max(self.lateral_peak_mps2, abs(self.vehicle.state.ay_mps2))

    def footprint(self, length_m: float, width_m: float, rear_m: float) -> np.ndarray:
        return self.vehicle.footprint_xy_m()


def run_closed_loop(config: AppConfig, track, laps: int, *, max_time_s: float = 200.0,
                    explore_waypoints: bool = False, dynamic: bool = False) -> LoopResult:
    """Drive ``laps`` autonomous laps of a simulator Track with perfect pose and a known map
    (``dynamic``: the simulator's vehicle model instead of the kinematic bicycle)."""
    config.controller.safety.auto_go = True
    planner = PathPlanner(config.planner, config.car)
    controller = Controller(config.controller, config.car, laps)
    car: Bicycle | DynamicAdapter = DynamicAdapter(config) if dynamic else bicycle_for(config)
    cones = cone_map(track.cones_xy_m, track.colours)
    dt = 1.0 / config.controller.rate_hz
    plan_every = max(int(round(config.controller.rate_hz / config.planner.rate_hz)), 1)

    def state(t: float) -> MapState:
        vy = car.vy_mps if isinstance(car, DynamicAdapter) else 0.0
        pose = PoseEstimate(t, car.x_m, car.y_m, car.yaw_rad, car.v_mps, vy, 0.0,
                            np.eye(3) * 1e-4)
        return MapState(t, pose, cones, loop_closed=True)

    if explore_waypoints:
        for p in track.centreline_xy_m[:: 3]:
            planner.book.record(float(p[0]), float(p[1]))
    planner.start_autonomous(state(0.0))
    health = Health(0.0, ())
    remote = RemoteStop(0.0, False, False)
    plan: Plan | None = None
    hits: set[int] = set()
    off = 0
    max_offset = 0.0
    max_frame_offset = 0.0
    max_plan_error = 0.0
    lap_times: list[float] = []
    trace: list[tuple[float, ...]] = []
    last_lap, last_lap_t = 0, math.nan
    t = 0.0
    step = 0
    while t < max_time_s:
        if step % plan_every == 0:
            plan = planner.plan(state(t), t)
            if plan.lap != last_lap:
                if math.isfinite(last_lap_t):
                    lap_times.append(t - last_lap_t)
                last_lap, last_lap_t = plan.lap, t
            elif last_lap == 0 and not math.isfinite(last_lap_t):
                last_lap_t = math.nan
        cmd = controller.command(t, state(t).pose, plan, health, remote)
        car.step(cmd, dt)
        t += dt
        step += 1
        fp = car.footprint(config.car.length_m, config.car.width_m, config.car.rear_overhang_m)
        hits.update(track.cones_touched(fp))
        if step % 10 == 0:
            if track.is_off_track(fp):
                off += 1
            _, lateral, _ = track.locate(car.x_m, car.y_m)
            max_offset = max(max_offset, abs(lateral))
            path = controller._path
            if path is not None and controller.state == AsState.DRIVING and t > 2.0:
                max_plan_error = max(max_plan_error, abs(path.nearest(car.x_m, car.y_m)[1]))
            if planner.frame is not None and controller.state == AsState.DRIVING and t > 2.0:
                max_frame_offset = max(max_frame_offset, planner.frame.distance_m(car.x_m,
                                                                                  car.y_m))
            if planner.frame is not None and controller.state == AsState.DRIVING:
                hint = trace[-1][1] if trace else None
                s_m, _ = planner.frame.project(car.x_m, car.y_m, hint)
                kappa = float(planner.frame.sample(s_m)[3])
                trace.append((t, s_m, kappa, cmd.steering_rad, car.v_mps,
                              float(id(planner.frame)), planner.frame.length_m))
        if controller.state in (AsState.FINISHED, AsState.EMERGENCY) and car.v_mps < 0.01:
            break
    return LoopResult(lap_times, hits, off, max_offset, max_frame_offset, max_plan_error,
                      controller.state, controller.stop_reason,
                      car.lateral_peak_mps2, t, np.asarray(trace, np.float64).reshape(-1, 7))


def body_gaps_m(generator: ManoeuvreGenerator, xy_m: np.ndarray, heading_rad: np.ndarray,
                cones_xy_m: np.ndarray) -> np.ndarray:
    """The gap (m) from the circles covering the car's body to the nearest cone centre at each
    point (K,) of a path: xy (K, 2) (m), heading (K,) (rad)."""
    along = np.stack([np.cos(heading_rad), np.sin(heading_rad)], axis=1)
    centres = xy_m[:, None, :] + generator.circle_offsets_m[None, :, None] * along[:, None, :]
    dist = np.linalg.norm(centres[:, :, None, :] - cones_xy_m[None, None, :, :], axis=-1)
    return dist.min(axis=(1, 2)) - generator.circle_radius_m
