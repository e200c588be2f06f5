"""The safety supervisor: the Formula Student autonomous-system state machine, checked every tick.

Faults and their response (issue 7, seed 002 3.1.3):

- the remote emergency stop, or a stale critical sensor -> EMERGENCY at once (full braking);
- a plan with no manoeuvre, a late plan (older than the timeout) whose manoeuvre no longer
  covers a controlled stop or older than its maximum age, a pose that is not finite or too
  uncertain, leaving the track corridor -> a controlled stop, then EMERGENCY at standstill
  (a late plan that still covers a stop is followed, slower: see the Controller);
- the end of the run (lap count reached) -> a controlled stop, then FINISHED at standstill.

The AS state itself is kept by ONE :class:`controller.as_state_machine.AsStateMachine` (the FSD
state machine with the rules' timings, built by Main): the supervisor feeds it every tick and
reads its state. Legal transitions (FS rules): OFF -> READY -> DRIVING -> FINISHED; READY,
DRIVING, FINISHED -> EMERGENCY; READY, FINISHED, EMERGENCY -> OFF. A stop latches: once a
reason is set, the car stops; only a new run (reset) clears it.
"""

from __future__ import annotations

import dataclasses
import enum
import logging
import math
from dataclasses import dataclass

import numpy as np

from common.messages import (
    AsState,
    Health,
    Mission,
    Plan,
    PoseEstimate,
    RemoteStop,
    TargetStates,
)
from controller.as_state_machine import AsInputs, AsStateMachine
from controller.config import AsStateMachineConfig, SafetyConfig

logger = logging.getLogger(__name__)

LEGAL_TRANSITIONS: dict[AsState, frozenset[AsState]] = {
    AsState.OFF: frozenset({AsState.READY}),
    AsState.READY: frozenset({AsState.DRIVING, AsState.EMERGENCY, AsState.OFF}),
    AsState.DRIVING: frozenset({AsState.EMERGENCY, AsState.FINISHED}),
    AsState.FINISHED: frozenset({AsState.EMERGENCY, AsState.OFF}),
    AsState.EMERGENCY: frozenset({AsState.OFF}),
}


def manoeuvre_ahead_m(manoeuvre: TargetStates, x_m: float, y_m: float) -> float:
    """Length (m) of the manoeuvre's path from its point nearest (x, y) to its end; 0 for a
    manoeuvre of fewer than two states."""
    x, y = manoeuvre.x_m, manoeuvre.y_m
    if len(x) < 2:
        return 0.0
    seg = np.hypot(np.diff(x), np.diff(y))
    nearest = int(np.argmin((x - x_m) ** 2 + (y - y_m) ** 2))
    return float(np.sum(seg[nearest:]))


def late_stop_distance_m(speed_mps: float, config: SafetyConfig) -> float:
    """Distance (m) a controlled stop from ``speed_mps`` takes, with the reaction time and the
    margin a late plan must leave (:class:`SafetyConfig`)."""
    return (speed_mps * speed_mps / (2.0 * config.stop_decel_mps2)
            + speed_mps * config.late_plan_reaction_s + config.late_plan_margin_m)


def late_plan_speed_mps(room_m: float, config: SafetyConfig, decel_mps2: float | None = None
                        ) -> float:
    """The highest speed (m/s) whose :func:`late_stop_distance_m` fits in ``room_m``; with
    ``decel_mps2``, a stop at that deceleration instead of ``config.stop_decel_mps2``."""
    a = config.stop_decel_mps2 if decel_mps2 is None else decel_mps2
    t = config.late_plan_reaction_s
    room = max(room_m - config.late_plan_margin_m, 0.0)
    return -a * t + math.sqrt((a * t) ** 2 + 2.0 * a * room)


def late_plan_cap_rate_mps2(speed_mps: float, cap_mps: float, config: SafetyConfig) -> float:
    """How fast (m/s^2, <= 0) the controller's late-plan speed cap falls while the car drives
    on at ``speed_mps``: the room shrinks at the car's speed, and the cap ``cap_mps`` with it,
    at -speed / (d room / d cap) = -speed / (cap / a + reaction) (``a``:
    ``config.late_plan_slow_decel_mps2``). The controller brakes at least this hard while the
    cap holds it back, so the car slows with the cap instead of a speed loop's lag behind."""
    a = config.late_plan_slow_decel_mps2
    return -max(speed_mps, 0.0) / (max(cap_mps, 0.0) / a + config.late_plan_reaction_s)


class StopKind(enum.IntEnum):
    """How the car must stop now."""

    NONE = 0
    CONTROLLED = 1
    """Braking at the set deceleration to standstill."""
    EMERGENCY = 2
    """Full braking at once."""


@dataclass(frozen=True, slots=True)
class SafetyStatus:
    """The supervisor's verdict for one tick."""

    state: AsState
    stop: StopKind
    reason: str


class SafetySupervisor:
    """Checks every control tick and drives the AS state (see the module docstring).

    The AS state is that of ONE :class:`~controller.as_state_machine.AsStateMachine`
    (``machine``): each tick feeds it what the stack knows (the selected mission, the RES,
    stale sensors, the supervisor's own stops) and reads its state back. Main builds the machine
    with the rules' timings (``[controller.as_state]``) and hands the supervisor the mission from
    ``MISSION_SELECT`` (:meth:`select_mission`); without a machine (a controller used on its own:
    tests, tools) the supervisor makes one whose mission is selected and whose go counts at once
    (after ``min_ready_time_s``), with no wait before moving.

    ``laps``: autonomous laps after which the run ends (None or <= 0: no lap limit).
    """

    def __init__(self, config: SafetyConfig, laps: int | None = None,
                 machine: AsStateMachine | None = None) -> None:
        self.config = config
        self.laps = laps if laps is not None and laps > 0 else None
        self.standalone = machine is None
        if machine is None:
            machine = AsStateMachine(AsStateMachineConfig(
                min_ready_s=config.min_ready_time_s, min_driving_before_move_s=0.0,
                ignore_early_go=False))
        self.machine = machine
        self.mission: Mission | None = Mission.TRACKDRIVE if self.standalone else None
        """The mission the car selects (None: no ``MISSION_SELECT`` yet)."""
        self.stop = StopKind.NONE
        self.stop_reason = ""
        self.stop_time_s = math.nan
        self._no_path_since_s = math.nan
        self._inputs = AsInputs(mission=self.mission, asms_on=True, asb_ok=True)
        self.late_plan_ticks = 0
        """Ticks driven on a late plan that still covered a stop."""

    # ------------------------------------------------------------------ state machine
    @property
    def state(self) -> AsState:
        """The AS state (the machine's)."""
        return self.machine.state

    @property
    def transitions(self) -> list[tuple[float, AsState, AsState, str]]:
        """Every AS transition as ``(time_s, from, to, reason)`` (the machine's)."""
        return self.machine.transitions

    def select_mission(self, mission: Mission | None) -> None:
        """The mission the car selects (``MISSION_SELECT``); the machine reads it each tick."""
        self.mission = mission

    def _step(self, now_s: float, **changes: object) -> AsState:
        """Step the machine with the last inputs, changed by ``changes``."""
        self._inputs = dataclasses.replace(self._inputs, **changes)  # type: ignore[arg-type]
        return self.machine.step(now_s, self._inputs)

    def transition(self, now_s: float, new: AsState, reason: str = "") -> bool:
        """Ask the machine for ``new`` if the FS state machine allows it; False (and a log)
        if not, or if the machine's conditions for it do not hold."""
        if new == self.state:
            return True
        if new not in LEGAL_TRANSITIONS[self.state]:
            logger.warning("illegal AS transition %s -> %s refused (%s)", self.state.name,
                           new.name, reason)
            return False
        if new == AsState.READY:
            self._step(now_s, mission=self.mission, stack_blocker="", res_go=False)
        elif new == AsState.DRIVING:
            self._step(now_s, res_go=False)
            self._step(now_s, res_go=True)
        elif new == AsState.EMERGENCY:
            self._step(now_s, failure=reason or "emergency")
        elif new == AsState.FINISHED:
            self._step(now_s, mission_finished=True, speed_mps=0.0)
        else:
            self.machine.reset(now_s)
        return self.state == new

    def arm(self, now_s: float) -> bool:
        """OFF -> READY."""
        return self.transition(now_s, AsState.READY, "armed")

    def go(self, now_s: float) -> bool:
        """READY -> DRIVING (the RES go), after the machine's minimum time in READY."""
        if self.state != AsState.READY:
            return False
        return self.transition(now_s, AsState.DRIVING, "go")

    def may_move(self, now_s: float) -> bool:
        """True once the machine lets the car move (DRIVING for its minimum time)."""
        return self.machine.may_move(now_s)

    def request_stop(self, now_s: float, kind: StopKind, reason: str) -> None:
        """Latch a stop; an emergency overrides a controlled stop, never the other way."""
        if kind <= self.stop:
            return
        if self.stop == StopKind.NONE:
            self.stop_reason = reason
            self.stop_time_s = now_s
            logger.warning("stop (%s) at %.3f s: %s", kind.name.lower(), now_s, reason)
        elif kind == StopKind.EMERGENCY:
            self.stop_reason = f"{self.stop_reason}; then {reason}"
            logger.warning("emergency at %.3f s: %s", now_s, reason)
        self.stop = kind
        if kind == StopKind.EMERGENCY and self.state != AsState.OFF:
            self.transition(now_s, AsState.EMERGENCY, reason)

    def standstill(self, now_s: float) -> None:
        """The car stands after a controlled stop: FINISHED for the end of the run, else
        EMERGENCY."""
        if self.stop != StopKind.CONTROLLED or self.state != AsState.DRIVING:
            return
        if self.stop_reason.startswith("finished"):
            self.transition(now_s, AsState.FINISHED, self.stop_reason)
        else:
            self.transition(now_s, AsState.EMERGENCY, self.stop_reason)

    # ------------------------------------------------------------------ checks
    def check(
        self,
        now_s: float,
        pose: PoseEstimate | None,
        plan: Plan | None,
        health: Health | None,
        remote: RemoteStop | None,
    ) -> SafetyStatus:
        """One tick: step the AS state machine from the inputs and say how to stop, if at all.

        The machine leaves OFF with a drivable mission once the stack has a pose and fresh
        critical sensors (and, with ``auto_arm`` off, never by itself); READY -> DRIVING on the
        RES go (``auto_go``: without one), refused while a critical sensor is stale. While
        DRIVING before the machine lets the car move, only emergencies are checked.
        """
        c = self.config
        emergency = remote is not None and remote.emergency
        if emergency and self.state != AsState.OFF:
            self.request_stop(now_s, StopKind.EMERGENCY, "remote emergency stop")
        stale = self._stale_critical(health)
        if self.state == AsState.READY and stale:
            logger.debug("go refused: stale %s", stale)
        go = ((remote is not None and remote.go) or c.auto_go) and not stale
        blocker = ""
        if self.state == AsState.OFF and self.mission is not None and self.mission.selectable:
            if not c.auto_arm:
                blocker = "not armed (controller.safety.auto_arm is off)"
            elif stale:
                blocker = f"stale sensor: {', '.join(stale)}"
            elif pose is None:
                blocker = "no pose yet"
        speed = pose.vx_mps if pose is not None and math.isfinite(pose.vx_mps) else math.nan
        self._inputs = AsInputs(
            mission=self.mission, asms_on=True, asb_ok=True, ts_active=True,
            brakes_engaged=True, res_go=go, res_emergency=emergency,
            failure=self.stop_reason if self.stop == StopKind.EMERGENCY else "",
            mission_finished=False, speed_mps=speed,
            lap=plan.lap if plan is not None else 0, stack_blocker=blocker)
        self.machine.step(now_s, self._inputs)
        if self.state == AsState.DRIVING and self.may_move(now_s):
            if stale:
                self.request_stop(now_s, StopKind.EMERGENCY, f"stale sensor: {', '.join(stale)}")
            reason = self._controlled_stop_reason(now_s, pose, plan)
            if reason:
                self.request_stop(now_s, StopKind.CONTROLLED, reason)
        elif self.state == AsState.DRIVING and stale:
            self.request_stop(now_s, StopKind.EMERGENCY, f"stale sensor: {', '.join(stale)}")
        if self.state == AsState.EMERGENCY:
            self.stop = StopKind.EMERGENCY
            if not self.stop_reason:
                self.stop_reason = self.machine.reason
                self.stop_time_s = now_s
        return SafetyStatus(self.state, self.stop, self.stop_reason)

    def _stale_critical(self, health: Health | None) -> tuple[str, ...]:
        if health is None:
            return ()
        critical = set(self.config.critical_sources)
        return tuple(s for s in health.stale_sources() if s in critical)

    def _controlled_stop_reason(
        self, now_s: float, pose: PoseEstimate | None, plan: Plan | None
    ) -> str:
        c = self.config
        if pose is None:
            return "no pose"
        values = (pose.x_m, pose.y_m, pose.yaw_rad, pose.vx_mps, pose.vy_mps)
        if not all(math.isfinite(v) for v in values) or not np.all(np.isfinite(pose.covariance)):
            return "non-finite pose"
        pose_age_s = now_s - pose.timestamp_s
        if pose_age_s > c.pose_max_age_s:
            return f"map too old: {pose_age_s:.3f} s"
        cov = pose.covariance
        limit = c.max_position_sigma_m
        # no eigenvalue of the symmetric block [[a, b], [b, d]] exceeds max(a, d) + |b|
        # (Gershgorin): well inside the limit the eigenvalues need not be computed
        bound = max(float(cov[0, 0]), float(cov[1, 1])) + abs(float(cov[1, 0]))
        if not (limit >= 0.0 and bound < 0.999 * limit * limit):
            sigma_xy = math.sqrt(max(float(np.linalg.eigvalsh(cov[:2, :2]).max()), 0.0))
            if sigma_xy > limit:
                return f"pose uncertain: position sigma {sigma_xy:.2f} m"
        sigma_yaw = math.sqrt(max(float(cov[2, 2]), 0.0))
        if sigma_yaw > c.max_yaw_sigma_rad:
            return f"pose uncertain: yaw sigma {sigma_yaw:.2f} rad"
        if plan is None:
            return "no plan"
        age = now_s - plan.timestamp_s
        if age > c.plan_timeout_s:
            if age > c.plan_max_age_s:
                return f"plan too old: {age:.3f} s"
            ahead = manoeuvre_ahead_m(plan.manoeuvre, pose.x_m, pose.y_m)
            need = late_stop_distance_m(max(pose.vx_mps, 0.0), c)
            # a standing car (at the end of the track seen so far) needs no room to stop in
            if ahead < need and pose.vx_mps > c.standstill_speed_mps:
                return (f"plan too old: {age:.3f} s, its {ahead:.1f} m ahead do not cover a "
                        f"stop ({need:.1f} m)")
            self.late_plan_ticks += 1
        if self.laps is not None and plan.lap >= self.laps:
            return f"finished: {plan.lap} laps"
        # no manoeuvre (exploring: the track seen so far ends at the car) or none feasible:
        # the controller brakes, and the planner has no_path_timeout_s to find one again (a
        # busy computer maps the next cones late)
        if len(plan.manoeuvre) == 0 or plan.chosen_index < 0:
            if not math.isfinite(self._no_path_since_s):
                self._no_path_since_s = now_s
            elif now_s - self._no_path_since_s > c.no_path_timeout_s:
                return "no manoeuvre" if len(plan.manoeuvre) == 0 else "no feasible path"
        else:
            self._no_path_since_s = math.nan
        bf = plan.baseframe
        if bf is not None and len(bf.x_m):
            dist = float(np.sqrt(np.min((bf.x_m - pose.x_m) ** 2 + (bf.y_m - pose.y_m) ** 2)))
            if dist > c.track_half_width_m + c.corridor_margin_m:
                return f"left the track corridor: {dist:.2f} m from the baseframe"
        return ""
