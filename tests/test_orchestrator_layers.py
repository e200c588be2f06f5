"""The layers Main steps in simulation and replay and ``drive`` runs on the car: each layer's
rate keeper, when planning starts, what the reactive layer takes and commands, what the
executive layer admits. The managers are stand-ins that count their calls (unit tests)."""

from __future__ import annotations

from types import SimpleNamespace
from typing import Any

import pytest

from common.messages import (
    ActuatorCommand,
    AsState,
    GpsFix,
    Health,
    Mission,
    MissionSelect,
    PoseEstimate,
    RawBytes,
    RemoteStop,
    WheelSpeeds,
)
from orchestrator.layers import DeliberativeLayer, ExecutiveLayer, RateKeeper, ReactiveLayer

TICK_S = 0.01  # the default control period


def test_a_rate_keeper_is_due_once_per_period_on_the_ticks() -> None:
    keeper = RateKeeper("planner", 10.0)
    due = [k for k in range(101) if keeper.due(k * TICK_S)]
    assert due == list(range(0, 101, 10))
    assert keeper.lags_s and max(keeper.lags_s) < 1e-9  # on time on a simulated clock


def test_a_stalled_layer_catches_up_with_one_step_and_reports_its_lag() -> None:
    keeper = RateKeeper("planner", 10.0)
    assert keeper.due(0.0)
    assert keeper.due(0.35)  # 0.25 s late: more than a period
    assert not keeper.due(0.40)  # no burst of the steps it missed
    assert keeper.due(0.45)
    summary = keeper.summary_ms()
    assert summary["steps"] == 3 and summary["late"] == 1
    assert summary["lag_max_ms"] == pytest.approx(250.0)


def test_a_rate_keeper_refuses_a_rate_that_is_not_positive() -> None:
    with pytest.raises(ValueError, match="rate must be > 0"):
        RateKeeper("planner", 0.0)


class Planner:
    def __init__(self) -> None:
        self.observed = 0
        self.started = 0
        self.plans: list[float] = []

    def observe(self, map_state: Any) -> None:
        self.observed += 1

    def start_autonomous(self, map_state: Any) -> None:
        self.started += 1

    def plan(self, map_state: Any, now_s: float) -> Any:
        self.plans.append(now_s)
        return SimpleNamespace(timestamp_s=now_s)


@pytest.mark.parametrize("why", ["loop_closed", "go", "driving"])
def test_planning_starts_at_the_loop_closure_the_go_or_once_driving(why: str) -> None:
    planner = Planner()
    layer = DeliberativeLayer(planner, 10.0)
    waiting: Any = SimpleNamespace(loop_closed=False)
    assert all(layer.step(k * TICK_S, waiting, False, False) is None for k in range(50))
    assert planner.started == 0 and not planner.plans
    ready: Any = SimpleNamespace(loop_closed=why == "loop_closed")
    plans = [layer.step(k * TICK_S, ready, why == "go", why == "driving")
             for k in range(50, 100)]
    assert planner.started == 1
    assert planner.plans == pytest.approx([k * TICK_S for k in range(50, 100, 10)])
    assert sum(p is not None for p in plans) == 5


def pose(t_s: float) -> PoseEstimate:
    return PoseEstimate(t_s, 0.0, 0.0, 0.0, vx_mps=5.0)


class Controller:
    def __init__(self) -> None:
        self.state = AsState.READY
        self.missions: list[Mission] = []
        self.remotes: list[RemoteStop | None] = []
        self.poses: list[PoseEstimate] = []
        self.config = SimpleNamespace(pose_prediction_max_s=0.3)

    def select_mission(self, mission: Mission) -> None:
        self.missions.append(mission)

    def command(self, now_s: float, pose: PoseEstimate, plan: Any, health: Health,
                remote: RemoteStop | None) -> ActuatorCommand:
        self.remotes.append(remote)
        self.poses.append(pose)
        return ActuatorCommand(now_s, 0.2, 0.0, 0.0, self.state)

    def as_status(self, now_s: float) -> Any:
        return self.state


def test_the_reactive_layer_takes_the_res_and_the_mission_and_brakes_without_a_pose() -> None:
    """... and hands the controller the pose carried forward to the tick."""
    controller = Controller()
    layer = ReactiveLayer(controller, 100.0, "trackdrive")
    layer.take([WheelSpeeds(0.0, 1.0, 1.0, 1.0, 1.0), RemoteStop(0.0, False, True),
                MissionSelect(0.0, Mission.TRACKDRIVE)])
    assert layer.go and controller.missions == [Mission.TRACKDRIVE]
    health = Health(0.0, ())
    waiting = layer.step(0.0, None, None, health)
    assert waiting.brake == 1.0 and waiting.throttle == 0.0 and waiting.state == AsState.READY
    assert not controller.remotes  # no pose: the controller is not asked
    controller.state = AsState.DRIVING
    plan: Any = SimpleNamespace(timestamp_s=0.05)
    command = layer.step(0.3, pose(0.28), plan, health)
    assert command.throttle == 0.2 and controller.remotes == [layer.remote]
    assert layer.pose_ages_s == pytest.approx([0.02])
    assert layer.plan_ages_s == pytest.approx([0.25])
    # the controller steers from where the car is: the pose 0.02 s on at its 5 m/s
    assert controller.poses[0].x_m == pytest.approx(0.1)


class Recorder:
    def __init__(self) -> None:
        self.raw: list[Any] = []
        self.fixes: list[GpsFix] = []

    def write_raw_many(self, units: Any) -> None:
        self.raw.extend(units)

    def write_gps_fix(self, fix: GpsFix) -> None:
        self.fixes.append(fix)


def test_the_executive_layer_records_everything_and_maps_only_fresh_readings() -> None:
    recorder = Recorder()
    updates: list[tuple[list[Any], float]] = []

    class Mapper:
        def update(self, readings: list[Any], now_s: float) -> Any:
            updates.append((list(readings), now_s))
            return SimpleNamespace(now_s=now_s)

    layer = ExecutiveLayer(Mapper(), stale_input_s=0.5, recorder=recorder)
    raw = [RawBytes(9.0, "gps", b"$GPGGA"), RawBytes(9.8, "gps", b"$GPGGA")]
    stale_fix, fresh_fix = GpsFix(9.0, 47.0, 8.0), GpsFix(9.8, 47.0, 8.0)
    wheels = WheelSpeeds(9.9, 1.0, 1.0, 1.0, 1.0)
    readings = layer.admit(10.0, raw, [stale_fix, fresh_fix, wheels])
    assert readings == [fresh_fix, wheels]
    assert recorder.raw == raw and recorder.fixes == [fresh_fix]  # all raw units recorded
    assert layer.rejected == {"stale_GpsFix": 1}
    layer.step(10.0, readings)
    assert updates == [([fresh_fix, wheels], 10.0)]
    assert layer.summary_ms()["lag_max_ms"] == pytest.approx(100.0)
