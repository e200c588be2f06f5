"""LiveMain (``drive``) end to end in-process: the control loop here, the executive process
spawned, CAN on a python-can virtual bus the test also listens to. No other sensors: this is
about the processes' plumbing, shutdown and the safe stop (the emulator tests drive a car)."""

from __future__ import annotations

import os
import signal
import sys
import threading
import time
import uuid
from pathlib import Path

import can
import pytest

from common.clock import RealClock
from common.messages import ActuatorCommand, AsState, CanFrame, RemoteStop, WheelSpeeds
from orchestrator.config import AppConfig
from orchestrator.layer_messages import ControlTick, Final, LayerError, Start, Stop
from orchestrator.live import CONTROL_SWITCH_INTERVAL_S, DriveOptions, LiveMain
from orchestrator.live_link import Link, link_pair
from orchestrator.live_worker import Worker
from recordings.player import Player
from recordings.reader import RecordingReader
from sensors.can_codec import CanCodec


def live_config() -> AppConfig:
    config = AppConfig()
    for name in ("gps", "imu", "lidar", "camera"):
        getattr(config.sensors, name).enabled = False
    config.sensors.can.interface = "virtual"
    config.sensors.can.channel = f"test-live-{uuid.uuid4().hex[:8]}"
    return config


class Car:
    """The other end of the virtual bus: sends wheel speeds, keeps the commands it gets."""

    def __init__(self, channel: str) -> None:
        self.bus = can.Bus(interface="virtual", channel=channel)
        self.codec = CanCodec()
        self.commands: list[ActuatorCommand] = []
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()

    def _run(self) -> None:
        t0 = time.monotonic()
        next_send = t0
        while not self.stop.is_set():
            msg = self.bus.recv(0.005)
            if msg is not None:
                command = self.codec.decode_command(
                    CanFrame(0.0, msg.arbitration_id, bytes(msg.data)))
                if command is not None:
                    self.commands.append(command)
            if time.monotonic() >= next_send:
                next_send += 0.02
                frame = self.codec.encode_wheel_speeds(
                    WheelSpeeds(time.monotonic() - t0, 0.0, 0.0, 0.0, 0.0))
                self.bus.send(can.Message(arbitration_id=frame.arbitration_id,
                                          data=frame.data, is_extended_id=False))

    def close(self) -> None:
        self.stop.set()
        self.thread.join(2.0)
        # the last frames may still be queued
        while (msg := self.bus.recv(0.0)) is not None:
            command = self.codec.decode_command(
                CanFrame(0.0, msg.arbitration_id, bytes(msg.data)))
            if command is not None:
                self.commands.append(command)
        self.bus.shutdown()


def ends_with_full_brake(commands: list[ActuatorCommand]) -> bool:
    last = commands[-5:]
    return len(last) == 5 and all(
        c.brake == 1.0 and c.throttle == 0.0 and c.state == AsState.EMERGENCY for c in last)


def kill_worker_when_running(main: LiveMain, sig: int, after_s: float) -> threading.Thread:
    def kill() -> None:
        end = time.monotonic() + 60.0
        while not main.worker_loaded and time.monotonic() < end:
            time.sleep(0.05)
        time.sleep(after_s)
        os.kill(main._process.pid, sig)

    thread = threading.Thread(target=kill, daemon=True)
    thread.start()
    return thread


@pytest.mark.slow
def test_time_limit_records_and_stops_with_full_brake(tmp_path: Path) -> None:
    config = live_config()
    car = Car(config.sensors.can.channel)
    main = LiveMain(config, DriveOptions(tmp_path, seconds=2.0, realtime_priority=0))
    try:
        summary = main.run()
    finally:
        car.close()
    assert summary["stop_reason"] == "time limit"
    assert (tmp_path / "summary.json").exists()
    timing = summary["timing"]
    assert timing["control_ticks"] >= 150
    assert isinstance(summary["outputs_sha256"], str)  # the executive process ended cleanly
    assert {h["source"] for h in summary["health"]} == {"can", "res"}
    # the wheel speeds reached the Mapper, its pose came back to the controller
    assert main.pose is not None
    assert len(car.commands) >= 150
    assert ends_with_full_brake(car.commands)
    # the recording: the commands and the CAN frames crossed to the executive process
    counts: dict[str, int] = {}
    recorded_commands: list[ActuatorCommand] = []
    for _t, topic, message in Player(tmp_path / "recording.mcap"):
        counts[topic] = counts.get(topic, 0) + 1
        if topic == "/command":
            recorded_commands.append(message)
    # The first tick's command, before any pose: held in READY, full brake. (The bus may not
    # carry it: the CAN sender sends the newest command, and a loaded machine may supersede
    # it before it goes out; the recording has every tick's.)
    first = recorded_commands[0]
    assert (first.state, first.brake, first.throttle) == (AsState.READY, 1.0, 0.0)
    assert counts.get("/command", 0) >= 150
    assert counts.get("/can/frame", 0) >= 50
    assert counts.get("/health", 0) >= 15


def test_executive_process_killed_stops_the_car(tmp_path: Path) -> None:
    config = live_config()
    car = Car(config.sensors.can.channel)
    main = LiveMain(config, DriveOptions(tmp_path, seconds=30.0, realtime_priority=0))
    kill_worker_when_running(main, signal.SIGKILL, 1.0)
    start = time.monotonic()
    try:
        summary = main.run()
    finally:
        car.close()
    assert time.monotonic() - start < 25.0
    assert "executive process died" in summary["stop_reason"], summary["stop_reason"]
    assert summary["outputs_sha256"] is None
    assert ends_with_full_brake(car.commands)


@pytest.mark.parametrize(("rate", "process"), [("output_record_rate_hz", "executive"),
                                               ("plan_rate_hz", "planner")])
def test_an_executive_process_that_cannot_start_stops_the_run(tmp_path: Path, rate: str,
                                                               process: str) -> None:
    """A rate of 0 Hz: the layer's rate keeper refuses it as its process starts (the output
    layer's in the executive process, the planner's in its own), and the run stops with that
    error before the car is driven."""
    config = live_config()
    setattr(config.run, rate, 0.0)
    car = Car(config.sensors.can.channel)
    try:
        summary = LiveMain(config, DriveOptions(tmp_path, seconds=30.0,
                                                realtime_priority=0)).run()
    finally:
        car.close()
    assert summary["stop_reason"].startswith(f"{process} start: ValueError"), summary
    assert "rate must be > 0" in summary["stop_reason"]
    assert not any(c.throttle > 0.0 for c in car.commands)  # the car was never driven
    assert summary["as_state"] != "DRIVING"
    if process == "executive":
        # the processes it had started (the recorder's, the planner's) were ended with it:
        # the recording is finished, not left open by a process waiting for its link
        with RecordingReader(tmp_path / "recording.mcap") as reader:
            assert reader.indexed


def test_a_failing_layer_thread_reports_its_error_and_closes_the_recording(
        tmp_path: Path) -> None:
    """The executive process's layers in-process (the planner's server in a thread, over the
    same link as its process), the planner's step made to fail once the RES says go: the
    worker sends the error, stops its threads, closes its recording and sends
    its statistics (LiveMain then stops the car: the test above)."""
    config = live_config()
    ours, theirs = link_pair()
    link, peer = Link(theirs), Link(ours)
    worker = Worker(config, DriveOptions(tmp_path, realtime_priority=0), RealClock(), link,
                    planner_in_thread=True)
    assert worker.planner_server is not None

    def fail(*_args: object) -> None:
        raise ZeroDivisionError("planned to fail")

    worker.planner_server.layer.step = fail  # type: ignore[method-assign,assignment]
    thread = threading.Thread(target=worker.run)
    thread.start()
    received: list[object] = []
    clock = RealClock()
    codec = CanCodec()
    try:
        peer.send(Start(clock))
        end = time.monotonic() + 20.0
        while not any(isinstance(m, Final) for m in received) and time.monotonic() < end:
            now_s = clock.now_s()
            speeds = WheelSpeeds(now_s, 0.0, 0.0, 0.0, 0.0)
            peer.send(ControlTick(now_s, (codec.encode_wheel_speeds(speeds),),
                                  (speeds, RemoteStop(now_s, emergency=False, go=True))))
            received.extend(peer.recv(0.05))
    finally:
        peer.send(Stop())
        thread.join(10.0)
        peer.close()
    errors = [m.text for m in received if isinstance(m, LayerError)]
    assert errors and errors[0].startswith("planner: ZeroDivisionError"), errors
    final = next(m for m in received if isinstance(m, Final))
    assert isinstance(final.stats["outputs_sha256"], str)
    assert (tmp_path / "recording.mcap").stat().st_size > 0
    assert not thread.is_alive()


@pytest.mark.skipif(not hasattr(os, "sched_setscheduler"), reason="no sched_setscheduler")
def test_realtime_priority_is_best_effort_and_restored(tmp_path: Path) -> None:
    config = live_config()
    before = os.sched_getscheduler(0)
    summary = LiveMain(config, DriveOptions(tmp_path, seconds=0.5, record=False,
                                            realtime_priority=5)).run()
    assert summary["stop_reason"] == "time limit"
    assert summary["timing"]["realtime_priority"] in (5, None)  # None: not permitted here
    assert os.sched_getscheduler(0) == before


def test_the_control_loop_runs_with_a_short_switch_interval_and_restores_it(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    seen: list[float] = []
    monkeypatch.setattr(LiveMain, "_loop", lambda self: seen.append(sys.getswitchinterval())
                        or "time limit")
    before = sys.getswitchinterval()
    summary = LiveMain(live_config(), DriveOptions(tmp_path, seconds=0.5, record=False,
                                                   realtime_priority=0)).run()
    assert summary["stop_reason"] == "time limit"
    assert seen == [pytest.approx(CONTROL_SWITCH_INTERVAL_S)]
    assert CONTROL_SWITCH_INTERVAL_S < before
    assert sys.getswitchinterval() == before
