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
                 standstill_s: float = 1.0, autonomous_exploration: bool = False,
                 ready_wait_s: float | None = None, move_delay_s: float = 0.0) -> None:
        """``autonomous_exploration``: nobody drives; the person only presses "go" once the car
        has stood ``standstill_s`` at the start, and the stack explores the first lap itself
        (its time is the first of :meth:`lap_times_s`).

        ``ready_wait_s`` (s; None: do not look): the person also waits until the ASSI has shown
        READY that long (the rules' 5 s), as the car decodes it from the stack's ``AS_STATUS``
        (``world.as_state_for_s``), before pressing go. ``move_delay_s`` (s): the car may move
        only this long after the go (the rules' 3 s in DRIVING): the first lap is timed from
        then (``start_time_s``)."""
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
        self.ready_wait_s = ready_wait_s
        self.move_delay_s = move_delay_s
        self.waiting_since_s = math.nan
        self.driving_seen_s = math.nan
        """When the car first showed DRIVING in ``AS_STATUS`` after the go (NaN: not seen)."""
        """When the person was ready to press go but the car was not READY long enough."""
        self.autonomous_crossings_s: list[float] = []
        self._still_since_s: float | None = None
        self._segment_hint: int | None = None
        """The centreline segment the car was last found on: the next search starts there."""

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
        progress_m, _, self._segment_hint = self.track.locate(truth.x_m, truth.y_m,
                                                              self._segment_hint)
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
                if t_s - self._still_since_s >= self.standstill_s and not self._car_ready(t_s):
                    if math.isnan(self.waiting_since_s):
                        self.waiting_since_s = t_s
                        log.info("the person waits for the ASSI to show READY for %.1f s",
                                 self.ready_wait_s or 0.0)
                elif t_s - self._still_since_s >= self.standstill_s:
                    self.phase = Phase.AUTONOMOUS
                    self.handover_time_s = t_s
                    self.world.send_go()
                    log.info("RES go: handover to the stack at t=%.2f s", t_s)
            else:
                self._still_since_s = None
        if self.phase == Phase.AUTONOMOUS and math.isnan(self.driving_seen_s):
            status = getattr(self.world, "as_status", None)
            if status is not None and status.state == AsState.DRIVING:
                self.driving_seen_s = float(self.world.as_state_since_s)
        if self.phase == Phase.AUTONOMOUS and crossed:
            self.autonomous_crossings_s.append(self.laps.crossings_s[-1])
            if self.autonomous_exploration and math.isnan(self.exploration_lap_time_s):
                self.exploration_lap_time_s = self.laps.crossings_s[-1] - self.start_time_s
        return crossed

    @property
    def start_time_s(self) -> float:
        """When the stack's first lap starts (s): the go (when the car showed DRIVING, else
        when the person pressed it) plus the wait before moving."""
        go_s = self.driving_seen_s if math.isfinite(self.driving_seen_s) else self.handover_time_s
        return go_s + self.move_delay_s

    def _car_ready(self, t_s: float) -> bool:
        """Has the ASSI shown READY for ``ready_wait_s`` (always True when not looking)?"""
        if self.ready_wait_s is None:
            return True
        shown = getattr(self.world, "as_state_for_s", None)
        return shown is not None and shown(t_s, AsState.READY) >= self.ready_wait_s

    def lap_times_s(self) -> list[float]:
        """Autonomous lap times (s): from the start (the go plus the wait before moving, a
        standing start) to each crossing."""
        crossings = self.autonomous_crossings_s
        if not crossings:
            return []
        starts = [self.start_time_s, *crossings[:-1]]
        return [round(end - start, 3) for start, end in zip(starts, crossings, strict=True)]
