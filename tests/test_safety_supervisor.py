"""Safety supervisor: FS AS state machine, emergency and controlled stops, stop reasons."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from safety_helpers import driving_controller, health, pose, straight_plan

from common.messages import AsState, Plan, PoseEstimate, RemoteStop, TargetStates
from controller.controller import Controller
from controller.safety import SafetySupervisor, StopKind
from orchestrator.config import AppConfig


def test_res_go_starts_and_the_car_drives() -> None:
    ctrl = driving_controller()
    cmd = ctrl.command(0.03, pose(0.03, v=5.0), straight_plan(0.03), health(0.03), None)
    assert cmd.throttle > 0.0 and cmd.brake == 0.0 and cmd.state == AsState.DRIVING
    assert ctrl.stop_reason == ""


def test_remote_emergency_brakes_fully_at_once() -> None:
    ctrl = driving_controller()
    cmd = ctrl.command(0.03, pose(0.03), straight_plan(0.03), health(0.03),
                       RemoteStop(0.03, True, False))
    assert cmd.brake == 1.0 and cmd.throttle == 0.0
    assert ctrl.state == AsState.EMERGENCY and cmd.state == AsState.EMERGENCY
    assert ctrl.stop_reason == "remote emergency stop"
    assert ctrl.stop_time_s == 0.03 and ctrl.stop_speed_mps == 10.0
    # latched: a later clean tick still brakes
    cmd = ctrl.command(0.5, pose(0.5), straight_plan(0.5), health(0.5), None)
    assert cmd.brake == 1.0 and ctrl.state == AsState.EMERGENCY


def test_stale_critical_sensor_is_an_emergency_but_gps_is_not() -> None:
    ctrl = driving_controller()
    cmd = ctrl.command(0.03, pose(0.03), straight_plan(0.03), health(0.03, ("gps",)), None)
    assert ctrl.state == AsState.DRIVING and cmd.brake == 0.0
    cmd = ctrl.command(0.04, pose(0.04), straight_plan(0.04), health(0.04, ("lidar",)), None)
    assert cmd.brake == 1.0 and ctrl.state == AsState.EMERGENCY
    assert ctrl.stop_reason == "stale sensor: lidar"


def run_controlled_stop(ctrl: Controller, make_inputs, v0: float = 10.0) -> list[float]:
    """Feed the controller while a point mass obeys its brake; returns the decelerations."""
    v, t = v0, 0.03
    decels = []
    for _ in range(1000):
        p, plan, h = make_inputs(t, v)
        cmd = ctrl.command(t, p, plan, h, None)
        assert cmd.throttle == 0.0
        decel = 12.0 * cmd.brake if v > 0 else 0.0
        v = max(v - decel * 0.01, 0.0)
        decels.append(decel)
        t += 0.01
        if ctrl.state != AsState.DRIVING:
            break
    return decels


@pytest.mark.parametrize(
    "fault, reason",
    [
        ("old_plan", "plan too old"),
        ("uncertain", "pose uncertain"),
        ("corridor", "left the track corridor"),
        ("nan", "non-finite pose"),
    ],
)
def test_faults_lead_to_a_controlled_stop_then_emergency(fault: str, reason: str) -> None:
    ctrl = driving_controller()
    fresh = straight_plan(-1.5)  # already older than a late plan may be (1 s)

    def inputs(t: float, v: float):
        if fault == "old_plan":
            return pose(t, v=v), fresh, health(t)  # never refreshed
        if fault == "uncertain":
            return pose(t, v=v, sigma=2.0), straight_plan(t), health(t)
        if fault == "corridor":
            return pose(t, y=4.0, v=v), straight_plan(t), health(t)
        return PoseEstimate(t, math.nan, 0.0, 0.0, v), straight_plan(t), health(t)

    decels = run_controlled_stop(ctrl, inputs)
    assert ctrl.stop_reason.startswith(reason)
    assert ctrl.state == AsState.EMERGENCY
    stop_decel = AppConfig().controller.safety.stop_decel_mps2
    braking = [d for d in decels[:-1] if d > 0.0]
    assert 0.8 * stop_decel < np.mean(braking) < 1.3 * stop_decel  # controlled, not full


def test_lap_count_reached_finishes_at_standstill() -> None:
    ctrl = driving_controller()
    decels = run_controlled_stop(ctrl, lambda t, v: (pose(t, v=v), straight_plan(t, lap=3),
                                                     health(t)))
    assert ctrl.state == AsState.FINISHED
    assert ctrl.stop_reason == "finished: 3 laps"
    assert max(decels[:-2]) < 12.0
    cmd = ctrl.command(20.0, pose(20.0, v=0.0), straight_plan(20.0, lap=3), health(20.0), None)
    assert cmd.brake > 0.0 and cmd.state == AsState.FINISHED


def test_illegal_transitions_are_refused() -> None:
    sup = SafetySupervisor(AppConfig().controller.safety, laps=1)
    assert not sup.transition(0.0, AsState.DRIVING)  # OFF -> DRIVING skips READY
    assert not sup.go(0.0)
    assert sup.arm(0.0) and sup.go(0.1)
    assert not sup.transition(0.2, AsState.READY)  # no way back from DRIVING
    sup.request_stop(0.3, StopKind.CONTROLLED, "finished: 1 laps")
    sup.request_stop(0.4, StopKind.CONTROLLED, "something else")
    assert sup.stop_reason == "finished: 1 laps"  # the first reason latches
    sup.standstill(1.0)
    assert sup.state == AsState.FINISHED
    assert not sup.transition(1.1, AsState.DRIVING)


def test_no_go_while_a_critical_sensor_is_stale() -> None:
    config = AppConfig()
    ctrl = Controller(config.controller, config.car, config.mission.laps)
    ctrl.command(0.0, pose(0.0), straight_plan(0.0), health(0.0), None)
    ctrl.command(0.01, pose(0.01), straight_plan(0.01), health(0.01, ("imu",)),
                 RemoteStop(0.01, False, True))
    assert ctrl.state == AsState.READY


def test_a_late_plan_that_covers_a_stop_is_followed_not_stopped_for() -> None:
    """On a busy computer the planner may be late: a plan older than the timeout (0.2 s) whose
    manoeuvre still reaches beyond a controlled stop is followed; only one that no longer
    does, or one older than its maximum age (1 s), stops the car, with a specific reason."""
    config = AppConfig()
    ctrl = driving_controller(config)
    late = straight_plan(0.02)  # 300 m of manoeuvre, never refreshed
    for k in range(3, 60):  # to 0.6 s: late, but far from its end
        t = 0.01 * k
        cmd = ctrl.command(t, pose(t, x=10.0 + 10.0 * t), late, health(t), None)
        assert ctrl.state == AsState.DRIVING and ctrl.safety.stop == StopKind.NONE, \
            ctrl.stop_reason
    assert cmd.brake == 0.0
    assert ctrl.safety.late_plan_ticks > 30
    # older than the maximum age: a controlled stop
    ctrl.command(1.1, pose(1.1, x=21.0), late, health(1.1), None)
    assert ctrl.safety.stop == StopKind.CONTROLLED
    assert ctrl.stop_reason.startswith("plan too old: 1.080 s")


def test_a_map_older_than_its_maximum_age_stops_the_car() -> None:
    """A pose (the map's) older than ``pose_max_age_s`` (0.5 s) while driving: a controlled
    stop with its own reason; one younger than that is driven on (the controller carries it
    forward by its own motion)."""
    ctrl = driving_controller()
    max_age = ctrl.config.safety.pose_max_age_s
    for k in range(3, 40):
        t = 0.01 * k
        ctrl.command(t, pose(min(t, 0.05)), straight_plan(t), health(t), None)
        assert ctrl.safety.stop == StopKind.NONE, ctrl.stop_reason  # up to 0.34 s old
    t = 0.05 + max_age + 0.02
    ctrl.command(t, pose(0.05), straight_plan(t), health(t), None)
    assert ctrl.safety.stop == StopKind.CONTROLLED
    assert ctrl.stop_reason == f"map too old: {max_age + 0.02:.3f} s"


def _without_manoeuvre(plan: Plan) -> Plan:
    """``plan`` with an empty manoeuvre and no candidate chosen (exploring: the track seen so
    far ends at the car)."""
    empty = np.zeros(0)
    return dataclasses.replace(
        plan, manoeuvre=TargetStates(empty, empty, empty, empty, empty, empty), chosen_index=-1)


def test_a_plan_without_manoeuvre_brakes_and_is_waited_for_before_the_run_ends() -> None:
    """No manoeuvre (the next cones not mapped yet): full brake at once, and the run goes on
    when a manoeuvre comes back within ``no_path_timeout_s`` (1.5 s); without one for longer,
    a controlled stop, "no manoeuvre"."""
    ctrl = driving_controller()
    timeout = ctrl.config.safety.no_path_timeout_s
    for k in range(3, 103):  # 1 s without a manoeuvre
        t = 0.01 * k
        cmd = ctrl.command(t, pose(t, v=1.0), _without_manoeuvre(straight_plan(t)), health(t),
                           None)
        assert ctrl.safety.stop == StopKind.NONE, ctrl.stop_reason
        assert cmd.brake == 1.0 and cmd.throttle == 0.0
    t = 1.03
    cmd = ctrl.command(t, pose(t, v=0.0), straight_plan(t), health(t), None)
    assert ctrl.safety.stop == StopKind.NONE and cmd.throttle > 0.0  # the path is back
    start = 1.04
    t = start
    while t < start + timeout + 0.05:
        ctrl.command(t, pose(t, v=0.0), _without_manoeuvre(straight_plan(t)), health(t), None)
        t += 0.01
    assert ctrl.safety.stop != StopKind.NONE  # controlled, at standstill at once: EMERGENCY
    assert ctrl.stop_reason == "no manoeuvre"
    assert ctrl.stop_time_s > start + timeout


def test_a_late_plan_that_ends_too_soon_stops_the_car() -> None:
    """At 10 m/s a controlled stop (6 m/s^2) takes 8.3 m, plus 0.2 s of reaction (2 m) and
    the 0.2 m margin: a late plan with 5 m of manoeuvre left ahead of the car ends the run."""
    ctrl = driving_controller()
    late = straight_plan(0.02)
    t = 0.4
    ctrl.command(t, pose(t, x=295.0), late, health(t), None)
    assert ctrl.safety.stop == StopKind.CONTROLLED
    assert "do not cover a stop" in ctrl.stop_reason


def test_a_late_plan_is_no_reason_to_stop_a_standing_car() -> None:
    """At the end of the track seen so far the car stands with no manoeuvre ahead: a late plan
    (0.3 s) is no stop while the car stands; once it rolls, the same plan stops it."""
    ctrl = driving_controller()
    late = straight_plan(0.02)
    t = 0.32
    ctrl.command(t, pose(t, x=300.0, v=0.0), late, health(t), None)
    assert ctrl.safety.stop == StopKind.NONE, ctrl.stop_reason
    t = 0.33
    ctrl.command(t, pose(t, x=300.0, v=1.0), late, health(t), None)
    assert "do not cover a stop" in ctrl.stop_reason


def test_a_late_plan_caps_the_speed_to_what_its_manoeuvre_lets_the_car_stop_in() -> None:
    """A plan asking 20 m/s with 15 m of manoeuvre left ahead of the car at 11 m/s (a stop at
    8 m/s^2 takes 7.6 m, 2.2 m of reaction and the 0.2 m margin: covered): fresh, the car
    accelerates toward 20 m/s; late, toward no more than 13.9 m/s, the speed from which a
    controlled stop with its reaction ends within the manoeuvre: less throttle."""
    from controller.safety import late_plan_speed_mps, late_stop_distance_m

    safety = AppConfig().controller.safety
    v_cap = late_plan_speed_mps(15.0, safety)
    assert safety.stop_decel_mps2 == 8.0 and safety.late_plan_reaction_s == 0.2
    assert v_cap == pytest.approx(13.87, abs=0.01)
    assert late_stop_distance_m(v_cap, safety) == pytest.approx(15.0)
    from controller.safety import manoeuvre_ahead_m

    plan = straight_plan(0.0, speed=20.0)
    assert manoeuvre_ahead_m(plan.manoeuvre, 284.5, 0.3) == pytest.approx(15.0)
    assert manoeuvre_ahead_m(plan.manoeuvre, 400.0, 0.0) == 0.0
    throttles = []
    for late in (False, True):
        ctrl = driving_controller()
        t = 0.4
        made = straight_plan(0.02 if late else t, speed=20.0)
        for k in range(5):
            now = t + 0.01 * k
            cmd = ctrl.command(now, pose(now, x=284.5, v=11.0), made, health(now), None)
        assert ctrl.safety.stop == StopKind.NONE
        throttles.append(cmd.throttle - cmd.brake)
    assert throttles[1] < throttles[0]
