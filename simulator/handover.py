"""The person at the side of the track: drives the exploration lap, then hands the car over.

On the car a person drives the exploration lap while the stack maps, stops the car past the
start line and presses "go" on the remote (RES). In simulation and in the hardware emulator
this class plays that person, and keeps the lap times measured on the ground truth.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field
from typing import Any

from common.messages import ActuatorCommand, AsState, GroundTruth

log = logging.getLogger(__name__)


@dataclass
class LapTimer:
    """Counts start-line crossings from the progress (m) along a closed track of length L (m).

    A crossing is a jump of the progress from the last quarter of the lap to the first quarter,
    in the driving direction, once the car has been in the middle half of the lap since the
    previous crossing (or the start); its time is interpolated between the two samples.
    """

    lap_length_m: float
    crossings_s: list[float] = field(default_factory=list)
    _last_progress_m: float | None = None
    _last_t_s: float = 0.0
    _half_way: bool = False
    """The car has been in the middle half of the lap since the last crossing (or the start):
    a car starting just behind the line does not count a lap when it rolls over it."""

    def update(self, t_s: float, progress_m: float) -> bool:
        """Feed one sample; True when the start line was crossed since the last one."""
        crossed = False
        last = self._last_progress_m
        length = self.lap_length_m
        if 0.25 * length <= progress_m <= 0.75 * length:
            self._half_way = True
        if last is not None:
            if last > 0.75 * length and progress_m < 0.25 * length and self._half_way:
                self._half_way = False
                ahead = (length - last) / max(length - last + progress_m, 1e-9)
                self.crossings_s.append(self._last_t_s + ahead * (t_s - self._last_t_s))
                crossed = True
        self._last_progress_m = progress_m
        self._last_t_s = t_s
        return crossed


class Phase:
    """Phases of a run, as the person at the side of the track sees it."""

    EXPLORATION = "exploration"
    STOPPING = "stopping"
    AUTONOMOUS = "autonomous"


class Handover:
    """Exploration lap by the scripted driver, a stop, then RES "go" and the stack's laps.

    ``world`` is a :class:`simulator.world.SimWorld` (for ``send_go``), ``driver`` a
    :class:`simulator.driver.ScriptedDriver`, ``track`` the world's track.
    """

    def __init__(self, track: Any, driver: Any, world: Any, *, overrun_m: float = 12.0,
                 standstill_s: float = 1.0, autonomous_exploration: bool = False) -> None:
        """``autonomous_exploration``: nobody drives; the person only presses "go" once the car
        has stood ``standstill_s`` at the start, and the stack explores the first lap itself
        (its time is the first of :meth:`lap_times_s`)."""
        self.track = track
        self.driver = driver
        self.world = world
        self.overrun_m = overrun_m
        self.standstill_s = standstill_s
        self.autonomous_exploration = autonomous_exploration
        self.phase = Phase.STOPPING if autonomous_exploration else Phase.EXPLORATION
        self.laps = LapTimer(track.lap_length_m)
        self.exploration_lap_time_s = math.nan
        self.handover_time_s = math.nan
        self.autonomous_crossings_s: list[float] = []
        self._still_since_s: float | None = None

    def command(self, t_s: float, truth: GroundTruth,
                stack_command: ActuatorCommand | None) -> ActuatorCommand | None:
        """What drives the car now: the person until handover, the stack after it."""
        if self.phase == Phase.AUTONOMOUS:
            return stack_command
        if getattr(self.world, "estop_active", False):
            # The person is not driving a stopped car: the RES trips the emergency brake system.
            return ActuatorCommand.full_brake(t_s)
        steer = self.driver.command(truth, t_s)
        if self.phase == Phase.EXPLORATION:
            return steer
        return ActuatorCommand(t_s, 0.0, 1.0, steer.steering_rad, AsState.READY)

    def observe(self, t_s: float, truth: GroundTruth) -> bool:
        """Update the phase and the lap timer from the truth; True on a start-line crossing."""
        progress_m = self.track.progress_m(truth.x_m, truth.y_m)
        # laps are of a loop (the acceleration straight and the skidpad's path are timed on
        # their lines: simulator/mission_timing.py)
        loop = getattr(self.track, "is_loop", True)
        crossed = self.laps.update(t_s, progress_m) if loop else False
        speed = math.hypot(truth.vx_mps, truth.vy_mps)
        if self.phase == Phase.EXPLORATION:
            if crossed and math.isnan(self.exploration_lap_time_s):
                self.exploration_lap_time_s = self.laps.crossings_s[-1]
            if not math.isnan(self.exploration_lap_time_s) and (
                self.overrun_m <= progress_m < 0.5 * self.track.lap_length_m
            ):
                self.phase = Phase.STOPPING
        elif self.phase == Phase.STOPPING:
            if speed < 0.05:
                if self._still_since_s is None:
                    self._still_since_s = t_s
                if t_s - self._still_since_s >= self.standstill_s:
                    self.phase = Phase.AUTONOMOUS
                    self.handover_time_s = t_s
                    self.world.send_go()
                    log.info("RES go: handover to the stack at t=%.2f s", t_s)
            else:
                self._still_since_s = None
        elif crossed:
            self.autonomous_crossings_s.append(self.laps.crossings_s[-1])
            if self.autonomous_exploration and math.isnan(self.exploration_lap_time_s):
                self.exploration_lap_time_s = self.laps.crossings_s[-1] - self.handover_time_s
        return crossed

    def lap_times_s(self) -> list[float]:
        """Autonomous lap times (s): from the handover (standing start) to each crossing."""
        crossings = self.autonomous_crossings_s
        if not crossings:
            return []
        starts = [self.handover_time_s, *crossings[:-1]]
        return [round(end - start, 3) for start, end in zip(starts, crossings, strict=True)]
