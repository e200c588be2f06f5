"""The Formula Student Driverless (FSD) autonomous-system (AS) state machine and the ASSI lamps.

A pure class: :meth:`AsStateMachine.step` takes the time (s, on the run's Clock) and what the
car reports (:class:`AsInputs`) and returns the AS state; nothing here reads a clock, a bus or a
file. States, per FS Rules 2026 v1.1, T14.8 and its Figure 15 (the AS state decision tree):

- ``OFF``: the start. It stays OFF (one log line each time the reason changes) until a mission
  the stack can drive is selected (``MISSION_SELECT``: not missing, ``NONE`` or ``UNKNOWN``),
  the ASMS is on, the EBS is armed (ASB checks OK), the tractive system is active and the
  brakes are engaged; then -> ``READY`` and the mission is latched.
- ``READY``: brakes held. -> ``DRIVING`` only on the RES go after at least
  ``min_ready_s`` (5 s, T14.8.4) in READY; a go already held when the wait ends does not count
  (``ignore_early_go``): it must be released and given again. -> ``OFF`` when a condition of
  READY is lost (the mission deselected or changed, ASMS off, ASB not OK, brakes released).
- ``DRIVING``: the mission runs; the car may move only after ``min_driving_before_move_s``
  (3 s, T14.8.5) in DRIVING (:meth:`AsStateMachine.may_move`). -> ``FINISHED`` when the
  mission reports finished and the car is at standstill. ASMS off or ASB not OK while driving
  is an EBS activation: -> ``EMERGENCY``.
- ``FINISHED``: the mission is over, the car stands. Latched.
- ``EMERGENCY``: from any state on the RES emergency stop or an EBS/safety failure
  (:attr:`AsInputs.failure`); from OFF only with the ASMS on (with it off the AS cannot
  activate the EBS). Latched: only :meth:`AsStateMachine.reset` (the ASMS switched off and the
  car staged again) leaves it. A RES stop in FINISHED (the SDC opened at the RES) is an
  emergency too, as in Figure 15.

ASSI (the status lamps, same section of the rules): OFF off, READY yellow continuous, DRIVING
yellow flashing, FINISHED blue continuous, EMERGENCY blue flashing; flashing at 2..5 Hz
(``assi_flash_hz``). The rule numbers were read from a summary of the 2026 rules (UM-Driverless
kart_docs, "AS state machine"); check them against the rules of the competition entered.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

from common.messages import AssiMode, AsState, AsStatus, Mission
from controller.config import AsStateMachineConfig

logger = logging.getLogger(__name__)

ASSI_BY_STATE: dict[AsState, AssiMode] = {
    AsState.OFF: AssiMode.OFF,
    AsState.READY: AssiMode.YELLOW_CONTINUOUS,
    AsState.DRIVING: AssiMode.YELLOW_FLASHING,
    AsState.FINISHED: AssiMode.BLUE_CONTINUOUS,
    AsState.EMERGENCY: AssiMode.BLUE_FLASHING,
}
"""What the ASSI lamps show in each AS state."""

_EPS_S = 1e-9


def assi_mode(state: AsState) -> AssiMode:
    """The ASSI mode of an AS state."""
    return ASSI_BY_STATE[state]


def assi_lamp_on(mode: AssiMode, now_s: float, flash_hz: float = 3.0) -> bool:
    """Is the lamp lit at ``now_s`` (s)? Flashing modes are lit the first half of each period
    of ``flash_hz`` (Hz)."""
    if mode == AssiMode.OFF:
        return False
    if mode in (AssiMode.YELLOW_FLASHING, AssiMode.BLUE_FLASHING):
        return (now_s * flash_hz) % 1.0 < 0.5
    return True


@dataclass(frozen=True, slots=True)
class AsInputs:
    """What the state machine needs each step (Main gathers it from the managers).

    ``mission``: the last ``MISSION_SELECT`` (None: no frame yet). ``asms_on``: the AS master
    switch. ``asb_ok``: the EBS is armed and the ASB checks pass. ``ts_active``: the tractive
    system is on. ``brakes_engaged``: the brakes hold the car (needed for READY).
    ``res_go`` / ``res_emergency``: the RES state. ``failure``: a non-empty reason is an EBS or
    safety failure (an emergency). ``mission_finished``: the mission (planner) reports its end.
    ``speed_mps``: the car's speed (m/s; NaN: unknown, never standstill). ``lap``: laps started,
    reported in ``AS_STATUS``. ``stack_blocker``: non-empty when the stack itself cannot take
    the car yet (no pose, a stale sensor): one more condition of OFF -> READY, with its reason.
    """

    mission: Mission | None = None
    asms_on: bool = False
    asb_ok: bool = False
    ts_active: bool = True
    brakes_engaged: bool = True
    res_go: bool = False
    res_emergency: bool = False
    failure: str = ""
    mission_finished: bool = False
    speed_mps: float = math.nan
    lap: int = 0
    stack_blocker: str = ""


class AsStateMachine:
    """The FSD AS state machine (see the module docstring).

    ``state`` is the current state, ``mission`` the mission latched on entering READY
    (``Mission.NONE`` before), ``reason`` why the last transition happened, ``transitions`` every
    transition as ``(time_s, from, to, reason)``.
    """

    def __init__(self, config: AsStateMachineConfig | None = None) -> None:
        self.config = config if config is not None else AsStateMachineConfig()
        self.state = AsState.OFF
        self.mission = Mission.NONE
        self.reason = ""
        self.lap = 0
        self.transitions: list[tuple[float, AsState, AsState, str]] = []
        self.entered_s = math.nan
        self._go_prev = False
        self._blockers: tuple[str, ...] = ()
        self._first_step_s = math.nan

    # ------------------------------------------------------------------ queries
    def time_in_state_s(self, now_s: float) -> float:
        """Time (s) since the current state was entered (inf when never changed)."""
        return now_s - self.entered_s if math.isfinite(self.entered_s) else math.inf

    def may_move(self, now_s: float) -> bool:
        """True once the car has been in DRIVING for ``min_driving_before_move_s`` (T14.8.5)."""
        return (self.state == AsState.DRIVING
                and self.time_in_state_s(now_s) + _EPS_S >= self.config.min_driving_before_move_s)

    @property
    def blockers(self) -> tuple[str, ...]:
        """Why the machine is held in OFF (empty when it is not, or not yet stepped)."""
        return self._blockers

    def assi(self) -> AssiMode:
        """The ASSI mode now."""
        return ASSI_BY_STATE[self.state]

    def status(self, now_s: float) -> AsStatus:
        """The ``AS_STATUS`` message for ``now_s`` (the lap of the last step)."""
        return AsStatus(now_s, self.state, self.mission, self.lap, self.assi())

    # ------------------------------------------------------------------ stepping
    def reset(self, now_s: float) -> None:
        """Back to OFF from any state (the ASMS switched off and the car staged again): the only
        way out of EMERGENCY and FINISHED."""
        self._go_to(now_s, AsState.OFF, "reset")
        self.mission = Mission.NONE
        self._blockers = ()

    def step(self, now_s: float, inputs: AsInputs) -> AsState:
        """Update the state at ``now_s`` (s) from ``inputs``; returns the new state."""
        if math.isnan(self._first_step_s):
            self._first_step_s = now_s
        go_edge = inputs.res_go and not self._go_prev
        self._go_prev = inputs.res_go
        self.lap = int(inputs.lap)
        state = self.state
        if state == AsState.EMERGENCY:
            return state
        emergency = _emergency_reason(inputs)
        if emergency and (state != AsState.OFF or inputs.asms_on):
            self._go_to(now_s, AsState.EMERGENCY, emergency, logging.WARNING)
        elif state == AsState.OFF:
            self._step_off(now_s, inputs)
        elif state == AsState.READY:
            self._step_ready(now_s, inputs, go_edge)
        elif state == AsState.DRIVING:
            self._step_driving(now_s, inputs)
        return self.state

    def _step_off(self, now_s: float, inputs: AsInputs) -> None:
        blockers = _ready_blockers(inputs)
        if (inputs.mission is None
                and now_s - self._first_step_s < self.config.mission_wait_s - _EPS_S):
            return  # the first MISSION_SELECT may still be on its way: nothing to say yet
        if blockers:
            if blockers != self._blockers:
                logger.log(logging.WARNING if _mission_blocked(inputs) else logging.INFO,
                           "AS stays OFF at %.3f s: %s", now_s, "; ".join(blockers))
            self._blockers = blockers
            return
        self._blockers = ()
        if inputs.mission is None:  # cannot happen without blockers; keeps mypy sure
            return
        self.mission = inputs.mission
        self._go_to(now_s, AsState.READY, f"mission {inputs.mission.name.lower()}")

    def _step_ready(self, now_s: float, inputs: AsInputs, go_edge: bool) -> None:
        blockers = _ready_blockers(inputs)
        if inputs.mission is not None and inputs.mission.selectable \
                and inputs.mission != self.mission:
            blockers += (f"mission changed from {self.mission.name.lower()} to "
                         f"{inputs.mission.name.lower()}",)
        if blockers:
            self._blockers = blockers
            self._go_to(now_s, AsState.OFF, "; ".join(blockers), logging.WARNING)
            self.mission = Mission.NONE
            return
        waited = self.time_in_state_s(now_s) + _EPS_S >= self.config.min_ready_s
        if not inputs.res_go:
            return
        if not waited:
            logger.debug("RES go at %.3f s ignored: %.3f s in READY, %.1f s needed", now_s,
                         self.time_in_state_s(now_s), self.config.min_ready_s)
        elif go_edge or not self.config.ignore_early_go:
            self._go_to(now_s, AsState.DRIVING, "RES go")

    def _step_driving(self, now_s: float, inputs: AsInputs) -> None:
        if not inputs.asms_on or not inputs.asb_ok:
            what = "ASMS switched off" if not inputs.asms_on else "ASB check failed"
            self._go_to(now_s, AsState.EMERGENCY, f"{what} while driving", logging.WARNING)
        elif inputs.mission_finished and _standstill(inputs, self.config):
            self._go_to(now_s, AsState.FINISHED, "mission finished, car at standstill")

    def _go_to(self, now_s: float, new: AsState, reason: str, level: int = logging.INFO) -> None:
        if new != self.state:
            logger.log(level, "AS %s -> %s at %.3f s: %s", self.state.name, new.name, now_s,
                       reason)
            self.transitions.append((now_s, self.state, new, reason))
        self.state = new
        self.reason = reason
        self.entered_s = now_s


def _emergency_reason(inputs: AsInputs) -> str:
    if inputs.res_emergency:
        return "RES emergency stop"
    if inputs.failure:
        return f"failure: {inputs.failure}"
    return ""


def _mission_blocked(inputs: AsInputs) -> bool:
    return inputs.mission is None or not inputs.mission.selectable


def _ready_blockers(inputs: AsInputs) -> tuple[str, ...]:
    """Why the conditions of READY (T14.8, Figure 15) do not hold; () when they all do."""
    out: list[str] = []
    if inputs.mission is None:
        out.append("no mission selected (no MISSION_SELECT frame received)")
    elif inputs.mission == Mission.NONE:
        out.append("no mission selected (MISSION_SELECT reports NONE)")
    elif inputs.mission == Mission.UNKNOWN:
        out.append("unknown mission (MISSION_SELECT value is no mission the stack can drive)")
    if not inputs.asms_on:
        out.append("ASMS off")
    if not inputs.asb_ok:
        out.append("EBS not armed or ASB checks not OK")
    if not inputs.ts_active:
        out.append("tractive system not active")
    if not inputs.brakes_engaged:
        out.append("brakes not engaged")
    if inputs.stack_blocker:
        out.append(f"stack not ready: {inputs.stack_blocker}")
    return tuple(out)


def _standstill(inputs: AsInputs, config: AsStateMachineConfig) -> bool:
    return math.isfinite(inputs.speed_mps) and abs(inputs.speed_mps) <= config.standstill_speed_mps
