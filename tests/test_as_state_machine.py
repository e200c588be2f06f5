"""The FSD AS state machine against the rules (FS Rules 2026 T14.8, Figure 15; T14.8.4 the 5 s in
READY before the go; T14.8.5 the 3 s in DRIVING before moving) and the ASSI per state.

Time is the simulated time handed to ``step``: no wall clock anywhere."""

from __future__ import annotations

import dataclasses
import itertools
import logging

import pytest

from common.messages import AssiMode, AsState, AsStatus, Mission
from controller.as_state_machine import (
    ASSI_BY_STATE,
    AsInputs,
    AsStateMachine,
    assi_lamp_on,
    assi_mode,
)
from controller.config import AsStateMachineConfig, ControllerConfig

ARMED = AsInputs(mission=Mission.AUTOCROSS, asms_on=True, asb_ok=True, speed_mps=0.0)
"""Everything READY needs, no go yet."""


def run(machine: AsStateMachine, t0_s: float, t1_s: float, inputs: AsInputs,
        dt_s: float = 0.01) -> AsState:
    """Step from ``t0_s`` to ``t1_s`` (inclusive) every ``dt_s`` with the same inputs."""
    n = round((t1_s - t0_s) / dt_s)
    for k in range(n + 1):
        machine.step(t0_s + k * dt_s, inputs)
    return machine.state


def ready_machine(t_s: float = 0.0) -> AsStateMachine:
    machine = AsStateMachine()
    assert machine.step(t_s, ARMED) == AsState.READY
    return machine


def driving_machine() -> AsStateMachine:
    machine = ready_machine(0.0)
    run(machine, 0.0, 5.0, ARMED)
    assert machine.step(5.01, dataclasses.replace(ARMED, res_go=True)) == AsState.DRIVING
    return machine


def test_default_config_has_the_rules_timings() -> None:
    config = AsStateMachineConfig()
    assert config.min_ready_s == 5.0 and config.min_driving_before_move_s == 3.0
    assert 2.0 <= config.assi_flash_hz <= 5.0
    assert ControllerConfig().as_state == config


def test_starts_off_with_the_assi_off() -> None:
    machine = AsStateMachine()
    assert machine.state == AsState.OFF and machine.mission == Mission.NONE
    assert machine.status(0.0) == AsStatus(0.0, AsState.OFF, Mission.NONE, 0, AssiMode.OFF)


@pytest.mark.parametrize("change", [
    {"mission": None}, {"mission": Mission.NONE}, {"mission": Mission.UNKNOWN},
    {"asms_on": False}, {"asb_ok": False}, {"ts_active": False}, {"brakes_engaged": False},
])
def test_off_to_ready_needs_every_condition(change: dict[str, object]) -> None:
    machine = AsStateMachine()
    assert run(machine, 0.0, 1.0, dataclasses.replace(ARMED, **change)) == AsState.OFF
    assert machine.step(1.01, ARMED) == AsState.READY
    assert machine.mission == Mission.AUTOCROSS
    assert machine.assi() == AssiMode.YELLOW_CONTINUOUS


@pytest.mark.parametrize("mission", [None, Mission.NONE, Mission.UNKNOWN])
def test_missing_or_unknown_mission_stays_off_with_one_log_line(
        mission: Mission | None, caplog: pytest.LogCaptureFixture) -> None:
    caplog.set_level(logging.INFO, logger="controller.as_state_machine")
    machine = AsStateMachine()
    assert run(machine, 0.0, 10.0, dataclasses.replace(ARMED, mission=mission,
                                                       res_go=True)) == AsState.OFF
    lines = [r for r in caplog.records if "stays OFF" in r.getMessage()]
    assert len(lines) == 1 and lines[0].levelno == logging.WARNING
    assert "mission" in lines[0].getMessage()
    assert machine.transitions == []


def test_every_mission_can_be_run() -> None:
    for mission in (Mission.TRACKDRIVE, Mission.AUTOCROSS, Mission.ACCELERATION,
                    Mission.SKIDPAD):
        machine = AsStateMachine()
        assert machine.step(0.0, dataclasses.replace(ARMED, mission=mission)) == AsState.READY
        assert machine.status(0.0).mission == mission


def test_ready_to_driving_only_after_5_s_and_the_go() -> None:
    machine = ready_machine(2.0)
    go = dataclasses.replace(ARMED, res_go=True)
    for t in (2.01, 4.0, 6.99):  # a go pressed and released inside the 5 s does nothing
        assert machine.step(t, go) == AsState.READY
        assert machine.step(t + 0.005, ARMED) == AsState.READY
    assert run(machine, 7.0, 9.0, ARMED) == AsState.READY  # waited, but no go
    assert machine.step(9.01, go) == AsState.DRIVING
    assert machine.transitions[-1][:3] == (9.01, AsState.READY, AsState.DRIVING)
    assert machine.assi() == AssiMode.YELLOW_FLASHING


def test_go_exactly_at_5_s_counts() -> None:
    machine = ready_machine(0.1)
    assert machine.step(5.1, dataclasses.replace(ARMED, res_go=True)) == AsState.DRIVING


def test_go_held_from_before_the_wait_must_be_given_again() -> None:
    go = dataclasses.replace(ARMED, res_go=True)
    machine = ready_machine(0.0)
    assert run(machine, 0.0, 8.0, go) == AsState.READY
    assert machine.step(8.01, ARMED) == AsState.READY  # released
    assert machine.step(8.02, go) == AsState.DRIVING  # given again


def test_go_held_counts_when_early_go_is_not_ignored() -> None:
    machine = AsStateMachine(AsStateMachineConfig(ignore_early_go=False))
    go = dataclasses.replace(ARMED, res_go=True)
    assert run(machine, 0.0, 4.99, go) == AsState.READY
    assert machine.step(5.0, go) == AsState.DRIVING


def test_ready_back_to_off_when_a_condition_is_lost() -> None:
    for change in ({"asms_on": False}, {"mission": Mission.NONE}, {"brakes_engaged": False},
                   {"mission": Mission.SKIDPAD}, {"asb_ok": False}):
        machine = ready_machine()
        assert machine.step(1.0, dataclasses.replace(ARMED, **change)) == AsState.OFF
        assert machine.mission == Mission.NONE
        # back to READY restarts the 5 s
        assert machine.step(2.0, ARMED) == AsState.READY
        assert machine.step(6.5, dataclasses.replace(ARMED, res_go=True)) == AsState.READY


def test_may_move_only_after_3_s_in_driving() -> None:
    machine = driving_machine()
    assert not machine.may_move(5.01) and not machine.may_move(8.0)
    assert machine.may_move(8.01)
    assert not ready_machine().may_move(100.0)


def test_driving_to_finished_needs_mission_finished_and_standstill() -> None:
    machine = driving_machine()
    moving = dataclasses.replace(ARMED, speed_mps=5.0, lap=3)
    assert machine.step(10.0, dataclasses.replace(moving, mission_finished=True)) \
        == AsState.DRIVING
    assert machine.step(11.0, dataclasses.replace(ARMED, speed_mps=0.0)) == AsState.DRIVING
    assert machine.step(12.0, dataclasses.replace(ARMED, mission_finished=True,
                                                  speed_mps=float("nan"))) == AsState.DRIVING
    assert machine.step(13.0, dataclasses.replace(ARMED, mission_finished=True, speed_mps=0.05,
                                                  lap=3)) == AsState.FINISHED
    assert machine.status(13.0) == AsStatus(13.0, AsState.FINISHED, Mission.AUTOCROSS, 3,
                                            AssiMode.BLUE_CONTINUOUS)
    # latched: nothing but an emergency or a reset leaves it
    assert run(machine, 13.0, 20.0, dataclasses.replace(ARMED, res_go=True)) == AsState.FINISHED
    assert run(machine, 20.0, 21.0, AsInputs()) == AsState.FINISHED


@pytest.mark.parametrize("trigger", [{"res_emergency": True}, {"failure": "EBS pressure low"}])
@pytest.mark.parametrize("state", [AsState.READY, AsState.DRIVING, AsState.FINISHED])
def test_emergency_from_any_state_and_latched(trigger: dict[str, object],
                                              state: AsState) -> None:
    machine = driving_machine() if state != AsState.READY else ready_machine()
    if state == AsState.FINISHED:
        machine.step(20.0, dataclasses.replace(ARMED, mission_finished=True))
    assert machine.state == state
    assert machine.step(30.0, dataclasses.replace(ARMED, **trigger)) == AsState.EMERGENCY
    assert machine.assi() == AssiMode.BLUE_FLASHING
    assert machine.transitions[-1][1:3] == (state, AsState.EMERGENCY)
    # latched: every input back to normal, a go, the ASMS off: still EMERGENCY
    for inputs in (ARMED, dataclasses.replace(ARMED, res_go=True), AsInputs()):
        assert run(machine, 31.0, 40.0, inputs, dt_s=0.5) == AsState.EMERGENCY
    machine.reset(41.0)
    assert machine.state == AsState.OFF and machine.mission == Mission.NONE
    assert machine.step(42.0, ARMED) == AsState.READY


def test_emergency_from_off_only_with_the_asms_on() -> None:
    machine = AsStateMachine()
    estop = AsInputs(res_emergency=True)
    assert run(machine, 0.0, 1.0, estop) == AsState.OFF  # ASMS off: the AS cannot brake
    assert machine.step(1.01, dataclasses.replace(estop, asms_on=True)) == AsState.EMERGENCY


@pytest.mark.parametrize("change", [{"asms_on": False}, {"asb_ok": False}])
def test_asms_off_or_asb_failure_while_driving_is_an_emergency(
        change: dict[str, object]) -> None:
    machine = driving_machine()
    assert machine.step(9.0, dataclasses.replace(ARMED, **change)) == AsState.EMERGENCY


def test_emergency_takes_precedence_over_go_and_finish() -> None:
    machine = ready_machine()
    assert machine.step(6.0, dataclasses.replace(ARMED, res_go=True, res_emergency=True)) \
        == AsState.EMERGENCY
    machine = driving_machine()
    assert machine.step(9.0, dataclasses.replace(ARMED, mission_finished=True,
                                                 failure="stale lidar")) == AsState.EMERGENCY
    assert machine.reason == "failure: stale lidar"


def machine_in(state: AsState) -> AsStateMachine:
    """A machine brought to ``state`` the legal way (READY entered at 0 s, DRIVING at 5.01 s)."""
    if state == AsState.OFF:
        return AsStateMachine()
    if state == AsState.READY:
        return ready_machine()
    machine = driving_machine()
    if state == AsState.FINISHED:
        machine.step(6.0, dataclasses.replace(ARMED, mission_finished=True))
    elif state == AsState.EMERGENCY:
        machine.step(6.0, dataclasses.replace(ARMED, res_emergency=True))
    assert machine.state == state
    return machine


def test_only_the_rules_transitions_happen() -> None:
    """From every state, one step with every combination of inputs (at 20 s: past every wait):
    each transition is one Figure 15 allows, and every allowed one happens."""
    allowed = {(AsState.OFF, AsState.READY), (AsState.OFF, AsState.EMERGENCY),
               (AsState.READY, AsState.OFF), (AsState.READY, AsState.DRIVING),
               (AsState.READY, AsState.EMERGENCY), (AsState.DRIVING, AsState.FINISHED),
               (AsState.DRIVING, AsState.EMERGENCY), (AsState.FINISHED, AsState.EMERGENCY)}
    seen: set[tuple[AsState, AsState]] = set()
    for start in AsState:
        for mission, asms, asb, go, estop, finished in itertools.product(
                (Mission.AUTOCROSS, Mission.UNKNOWN, None), *([(False, True)] * 5)):
            machine = machine_in(start)
            inputs = AsInputs(mission=mission, asms_on=asms, asb_ok=asb, res_go=go,
                              res_emergency=estop, mission_finished=finished, speed_mps=0.0)
            after = machine.step(20.0, inputs)
            if after != start:
                assert (start, after) in allowed, inputs
                seen.add((start, after))
    assert seen == allowed


def test_assi_per_state_and_flashing() -> None:
    assert ASSI_BY_STATE == {AsState.OFF: AssiMode.OFF,
                             AsState.READY: AssiMode.YELLOW_CONTINUOUS,
                             AsState.DRIVING: AssiMode.YELLOW_FLASHING,
                             AsState.FINISHED: AssiMode.BLUE_CONTINUOUS,
                             AsState.EMERGENCY: AssiMode.BLUE_FLASHING}
    assert all(assi_mode(s) == ASSI_BY_STATE[s] for s in AsState)
    times = [0.01 * k for k in range(100)]  # one second
    for mode in AssiMode:
        lit = [assi_lamp_on(mode, t, 3.0) for t in times]
        if mode == AssiMode.OFF:
            assert not any(lit)
        elif mode in (AssiMode.YELLOW_FLASHING, AssiMode.BLUE_FLASHING):
            changes = sum(a != b for a, b in zip(lit, lit[1:], strict=False))
            assert 5 <= changes <= 6  # 3 Hz: three on, three off
        else:
            assert all(lit)
