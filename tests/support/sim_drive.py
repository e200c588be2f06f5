"""Drives of the simulated car without the stack: what the Sensor Manager parses from the
simulator's bytes, with the ground truth. For the Mapper's tests.

The car is the simulator's (:mod:`simulator.world`), driven by the scripted driver (the
person of the exploration lap, :mod:`simulator.handover`): it drives one lap, stops a little
past the start line and stands. Every control tick (``run.control_rate_hz``) the world's raw
units go through a Sensor Manager as in a run; its readings arrive at that tick.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from common.clock import SimClock
from common.conventions import LocalTangentFrame, WorldFrame, wrap_angles
from common.messages import ActuatorCommand, AsState, ConeMap, ConeSize, Reading
from orchestrator.config import AppConfig
from orchestrator.managers import make_sensors
from simulator.driver import ScriptedDriver
from simulator.handover import Handover, Phase
from simulator.track import Track
from simulator.tracks import load_track
from simulator.world import SimWorld

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class Truth:
    """The true state at every control tick, each array (T,): time (s), position (m), yaw
    (rad, unwrapped), vehicle-frame velocity (m/s), yaw rate (rad/s)."""

    t_s: FloatArray
    x_m: FloatArray
    y_m: FloatArray
    yaw_rad: FloatArray
    vx_mps: FloatArray
    vy_mps: FloatArray
    yaw_rate_radps: FloatArray

    def at(self, t_s: float) -> tuple[float, float, float]:
        """(x_m, y_m, yaw_rad) interpolated at ``t_s`` (yaw wrapped to (-pi, pi])."""
        yaw = float(np.interp(t_s, self.t_s, self.yaw_rad))
        return (float(np.interp(t_s, self.t_s, self.x_m)),
                float(np.interp(t_s, self.t_s, self.y_m)),
                float(wrap_angles(yaw)))

    def index(self, t_s: float) -> int:
        """The tick at or just after ``t_s`` (clipped to the drive)."""
        return int(np.searchsorted(self.t_s, t_s).clip(0, self.t_s.size - 1))


@dataclass(frozen=True)
class Drive:
    """A drive: parsed readings with the tick they arrived at, the truth, the track, the GNSS
    world frame of the simulated world."""

    arrivals: list[tuple[float, Reading]]
    truth: Truth
    track: Track
    frame: WorldFrame
    duration_s: float
    exploration_lap_time_s: float
    """When the car crossed the start line at the end of its lap (s; NaN if it did not)."""

    @property
    def cones_xy_m(self) -> FloatArray:
        """The true cones (N, 2), world frame."""
        return self.track.cones_xy_m

    @property
    def cone_colours(self) -> NDArray[np.int64]:
        """The true cones' colours (N,)."""
        return self.track.colours

    def cone_map(self) -> ConeMap:
        """The true cones as a surveyed map (zero covariance)."""
        n = len(self.track.cones_xy_m)
        return ConeMap(self.track.cones_xy_m, np.zeros((n, 2, 2)), self.track.colours,
                       np.where(self.track.sizes > int(ConeSize.UNKNOWN), self.track.sizes,
                                int(ConeSize.SMALL)), np.ones(n), np.arange(n))

    def batches(self) -> Iterator[tuple[float, list[Reading]]]:
        """(tick time, the readings that arrived at it), every tick, as Main hands them on."""
        ticks = np.unique(self.truth.t_s)
        i = 0
        n = len(self.arrivals)
        for now in ticks.tolist():
            batch: list[Reading] = []
            while i < n and self.arrivals[i][0] <= now + 1e-9:
                batch.append(self.arrivals[i][1])
                i += 1
            yield now, batch

    def readings(self) -> list[Reading]:
        """Every reading in the order it was made (timestamp)."""
        return sorted((r for _, r in self.arrivals), key=lambda r: r.timestamp_s)


def simulated_drive(config: AppConfig, track: str | Track = "default", seed: int = 1,
                    seconds: float | None = None, stand_s: float = 1.0,
                    standstill_s: float = 0.0) -> Drive:
    """One exploration lap of ``track`` by the scripted driver in the simulated world of
    ``config`` (``seed`` draws its sensors' noise) and ``stand_s`` standing past the start line
    (a straight: to its end, and ``stand_s`` standing there); or the first ``seconds`` of it.
    With ``standstill_s`` the car first stands that long, braked (time for the IMU's static
    calibration)."""
    config = copy.deepcopy(config)
    config.sim.seed = seed
    the_track = load_track(track) if isinstance(track, str) else track
    world = SimWorld(config, the_track, seed)
    driver = ScriptedDriver(the_track, config.car, seed, speed_mps=config.sim.driver_speed_mps,
                            steer_noise_rad=config.sim.driver_steer_noise_rad)
    person = Handover(the_track, driver, world, overrun_m=config.run.exploration_overrun_m,
                      standstill_s=stand_s)
    clock = SimClock()
    sensors = make_sensors(config, clock, keep_raw=False)
    dt_s = 1.0 / config.run.control_rate_hz
    limit_s = seconds if seconds is not None else config.run.max_sim_time_s
    arrivals: list[tuple[float, Reading]] = []
    rows: list[tuple[float, ...]] = []
    k = 0
    moved, still_since_s = False, math.inf
    while True:
        k += 1
        t_s = k * dt_s
        truth = world.truth()
        if t_s <= standstill_s:
            command = ActuatorCommand(t_s, 0.0, 1.0, 0.0, AsState.READY)
        else:
            command = person.command(t_s, truth, None)
        raw = world.step_to(t_s, command)
        clock.set(t_s)
        sensors.ingest(raw)
        arrivals.extend((t_s, r) for r in sensors.take().readings)
        truth = world.truth()
        rows.append((t_s, truth.x_m, truth.y_m, truth.yaw_rad, truth.vx_mps, truth.vy_mps,
                     truth.yaw_rate_radps))
        person.observe(t_s, truth)
        if math.hypot(truth.vx_mps, truth.vy_mps) > 0.05:
            moved, still_since_s = True, math.inf
        elif moved:
            still_since_s = min(still_since_s, t_s)
        # A lap ends at the handover; a straight (acceleration) when the car stands at its end.
        if (person.phase == Phase.AUTONOMOUS or t_s - still_since_s >= stand_s
                or t_s >= limit_s - 1e-9):
            break
    columns = np.array(rows, np.float64).T
    columns[3] = np.unwrap(columns[3])
    enu = LocalTangentFrame(config.sim.origin_lat_deg, config.sim.origin_lon_deg,
                            config.sim.origin_alt_m)
    frame = WorldFrame(enu, 0.0, 0.0, config.sim.start_heading_enu_rad)
    return Drive(arrivals, Truth(*columns), the_track, frame, float(columns[0][-1]),
                 person.exploration_lap_time_s)

