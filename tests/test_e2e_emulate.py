"""End to end: ``main.py emulate`` and ``main.py drive`` in two processes (issue 9).

The emulator serves the simulated car over real transports (GPS and IMU on pseudo-terminals, CAN
through an slcan adapter on a pseudo-terminal, LiDAR and camera over UDP loopback) and writes a
car config; ``drive --config`` drives it as it would drive the car.

- ``test_drive_stops_cleanly_on_sigterm`` (short): drive receives every source (its
  ``summary.json`` health rates), its actuator frames reach the emulator, and SIGTERM ends it
  cleanly (summary written, recording closed).
- ``test_emulated_run_and_kill`` (long, one session): the scripted driver drives the exploration
  lap while drive maps, the RES "go" reaches drive (it commands DRIVING), drive drives off, then
  drive is killed with SIGKILL while the car moves and the emulated car brakes to a stop on its
  own (200 ms actuator watchdog), which ends the emulator. Whether drive keeps up with whole
  laps on a busy machine is `python main.py bench load`'s question (issue 19), not this test's:
  it kills drive as soon as the car moves under its command (the emulator logs it at 2 m/s),
  so a loaded test machine does not decide it.

Both keep all output in files under tmp_path; nothing here depends on wall-clock precision
except the figures printed for the report (control period p99).
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
import re
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from common.messages import AsState
from simulator.emulator import EmulatorOptions
from support.shared_data import shared_data

ROOT = Path(__file__).resolve().parents[1]
TRACK = ROOT.parent / "shared" / "data" / "tracks" / "eufs" / "small_track.csv"
SOURCES = ("gps", "imu", "can", "res", "lidar", "camera")


class Proc:
    """A ``main.py`` subprocess whose stdout and stderr go to files."""

    def __init__(self, name: str, args: list[str], folder: Path) -> None:
        self.name = name
        self.out_path = folder / f"{name}.out"
        self.err_path = folder / f"{name}.err"
        self._out = self.out_path.open("wb")
        self._err = self.err_path.open("wb")
        env = dict(os.environ, PYTHONUNBUFFERED="1")
        self.popen = subprocess.Popen([sys.executable, "main.py", *args], cwd=ROOT, env=env,
                                      stdout=self._out, stderr=self._err)

    def log(self) -> str:
        return self.err_path.read_text(errors="replace")

    def wait_for_log(self, pattern: str, timeout_s: float) -> re.Match[str]:
        """The first match of ``pattern`` in the process's stderr, waiting for it."""
        end = time.monotonic() + timeout_s
        while time.monotonic() < end:
            found = re.search(pattern, self.log())
            if found:
                return found
            if self.popen.poll() is not None:
                found = re.search(pattern, self.log())
                if found:
                    return found
                break
            time.sleep(0.1)
        raise AssertionError(f"{self.name}: no {pattern!r} within {timeout_s} s "
                             f"(rc {self.popen.poll()}):\n{self.log()[-3000:]}")

    def wait(self, timeout_s: float) -> int:
        try:
            return self.popen.wait(timeout_s)
        except subprocess.TimeoutExpired:
            raise AssertionError(f"{self.name} did not end within {timeout_s} s:\n"
                                 f"{self.log()[-3000:]}") from None

    def close(self) -> None:
        if self.popen.poll() is None:
            self.popen.kill()
            self.popen.wait(10.0)
        self._out.close()
        self._err.close()


@pytest.fixture
def procs() -> Iterator[list[Proc]]:
    started: list[Proc] = []
    yield started
    for proc in reversed(started):
        proc.close()


def start_emulator(folder: Path, procs: list[Proc], seconds: float) -> tuple[Proc, Path, Path]:
    """``emulate`` with its car config and summary in ``folder``; waits for the config."""
    shared_data("tracks", "eufs", "small_track.csv")
    car = folder / "car.toml"
    summary = folder / "emulator.json"
    emulator = Proc("emulate", ["emulate", "-v", "--track", str(TRACK), "--write-config",
                                str(car), "--summary", str(summary), "--seconds", str(seconds),
                                "--workdir", str(folder / "ports"),
                                # a person drives the first lap (its config tells drive so)
                                "--exploration", "manual"], folder)
    procs.append(emulator)
    end = time.monotonic() + 30.0
    while not car.exists():
        assert emulator.popen.poll() is None, emulator.log()
        assert time.monotonic() < end, "emulate wrote no car config"
        time.sleep(0.05)
    return emulator, car, summary


def check_car_config(car: Path) -> None:
    """The config points drive at ptys (GPS, IMU), slcan on a pty (CAN) and UDP loopback."""
    import tomllib

    config = tomllib.loads(car.read_text())
    sensors = config["sensors"]
    for name in ("gps", "imu"):
        port = Path(sensors[name]["port"])
        assert port.is_symlink() and os.path.realpath(port).startswith("/dev/pts/"), port
    assert sensors["can"]["interface"] == "slcan"
    assert os.path.realpath(sensors["can"]["channel"]).startswith("/dev/pts/")
    for name in ("lidar", "camera"):
        assert sensors[name]["host"] == "127.0.0.1"
        assert 0 < sensors[name]["port"] < 65536
    assert sensors["lidar"]["port"] != sensors["camera"]["port"]


def read_drive_recording(path: Path) -> tuple[np.ndarray, list[int], list[Any]]:
    """Log times (s) and AS states of drive's commands, and its recorded Health messages."""
    from recordings.player import Player

    times: list[float] = []
    states: list[int] = []
    health: list[Any] = []
    for log_time_s, topic, message in Player(path, topics=["/command", "/health"]):
        if topic == "/command":
            times.append(log_time_s)
            states.append(int(message.state))  # type: ignore[attr-defined]
        else:
            health.append(message)
    return np.asarray(times), states, health


@pytest.mark.slow
def test_drive_stops_cleanly_on_sigterm(tmp_path: Path, procs: list[Proc]) -> None:
    emulator, car, emulator_summary = start_emulator(tmp_path, procs, seconds=40.0)
    check_car_config(car)
    drive_dir = tmp_path / "drive"
    drive = Proc("drive", ["drive", "--config", str(car), "--laps", "1", "--out",
                           str(drive_dir)], tmp_path)
    procs.append(drive)
    emulator.wait_for_log(r"the stack opened the CAN adapter", 30.0)
    time.sleep(6.0)
    drive.popen.send_signal(signal.SIGTERM)
    assert drive.wait(15.0) == 0, drive.log()
    summary = json.loads((drive_dir / "summary.json").read_text())
    assert summary["stop_reason"] == "signal"
    rates = {h["source"]: h["rate_hz"] for h in summary["health"]}
    for source in SOURCES:
        assert rates.get(source, 0.0) > 0.0, (source, summary["health"])
    timing = summary["timing"]
    print(f"\ndrive (exploration, 6 s): control period p50 {timing['control_period_p50_ms']} ms, "
          f"p99 {timing['control_period_p99_ms']} ms, max {timing['control_period_max_ms']} ms "
          f"(target {timing['control_period_target_ms']} ms); health {rates}")
    assert timing["control_ticks"] > 300
    info = subprocess.run([sys.executable, "main.py", "info", str(drive_dir / "recording.mcap"),
                           "--json"], cwd=ROOT, capture_output=True, text=True, timeout=60,
                          check=False)
    assert info.returncode == 0, info.stderr
    recording = json.loads(info.stdout)
    assert recording["recovered"] is False  # closed cleanly
    for topic in ("/gps/nmea", "/imu/packet", "/can/frame", "/lidar/packet", "/camera/packet",
                  "/command", "/map/state", "/health"):
        assert recording["topics"][topic]["count"] > 0, topic

    emulator.popen.send_signal(signal.SIGTERM)
    assert emulator.wait(15.0) == 0, emulator.log()
    served = json.loads(emulator_summary.read_text())
    print(f"emulator: steps late p99 {served['step_late_p99_ms']} ms, "
          f"{served['steps_late']} steps over 100 ms")
    assert served["stop_reason"] == "signal"
    assert served["actuator_frames_in"] > 300  # drive's commands came back over slcan
    assert served["as_status_frames_in"] > 30  # and its AS_STATUS (10 Hz), decoded by the car
    assert served["mission_select"] == 1  # the car selected trackdrive
    # mission, pose, fresh sensors: READY (no go in these 6 s)
    assert "READY" in [t["state"] for t in served["as_transitions"]], served["as_transitions"]
    assert served["can_bad_lines"] == 0
    # its own lateness is measured (a step's units go out after the step's time, never before)
    assert 0.0 < served["step_late_p99_ms"] <= served["step_late_max_ms"]
    # a count of its steps (how many were late depends on the machine's load: 32-953 with
    # two busy processes beside the suite, so no bound from the run's other figures)
    step_s = next(f.default for f in dataclasses.fields(EmulatorOptions) if f.name == "step_s")
    steps = served["wall_time_s"] / float(step_s)  # type: ignore[arg-type]
    assert 0 <= served["steps_late"] <= steps + 1


FREEZE_MS = 500.0
"""How late the emulator's own step must be to explain a stop that names no stale sensor: the
stack's longest sensor timeout (GPS, RES: 0.5 s). CI's loaded machine once stopped every process
for 1.4 s during the exploration lap (issue 19)."""


def _session(folder: Path, procs: list[Proc]) -> tuple[Proc, Proc, Path, float, bool]:
    """emulate + drive: the scripted exploration lap, the RES go; returns the emulator, drive,
    the emulator's summary path, the handover time and whether the stack drove the car within
    45 s of the go (the rules' 3 s hold after it; on a loaded machine the racing line's worker
    process starts beside it: a generous wait)."""
    folder.mkdir(parents=True, exist_ok=True)
    emulator, car, emulator_summary = start_emulator(folder, procs, seconds=110.0)
    drive = Proc("drive", ["drive", "--config", str(car), "--laps", "2", "--out",
                           str(folder / "drive")], folder)
    procs.append(drive)
    emulator.wait_for_log(r"the stack opened the CAN adapter", 30.0)
    # The scripted exploration lap (~24 s on this track), a stop, then the RES go.
    go = emulator.wait_for_log(r"RES go: handover to the stack at t=([0-9.]+) s", 60.0)
    try:
        emulator.wait_for_log(r"the stack drives the car: ([0-9.]+) m/s", 45.0)
        drove = True
    except AssertionError:
        drove = False
    return emulator, drive, emulator_summary, float(go.group(1)), drove


STALE_LINE = re.compile(r"(\w+) stale: last reading ([0-9.]+) s ago; its reader proved "
                        r"([0-9.]+) s of silence \(timeout ([0-9.]+) s\)")
"""drive's log line when a source turns stale (sensors/manager.py): how old its last reading
was, and how much of that silence its receiver thread itself saw."""


def stack_froze_ms(drive_log: str) -> float:
    """The longest time (ms) one of drive's receiver threads was kept from running while its
    sensor kept sending: a stale source whose reader saw less silence than its timeout was
    not silent, the reader was late (the drive process starved). 0 when none."""
    froze = 0.0
    for _, age_s, seen_s, timeout_s in STALE_LINE.findall(drive_log):
        if float(seen_s) < float(timeout_s):
            froze = max(froze, 1000.0 * (float(age_s) - float(seen_s)))
    return froze


def freeze_needed_ms(drive_log: str) -> float:
    """How long a freeze of the machine must have been (ms) to explain drive's stop: the
    shortest timeout of the sources drive found stale (a 0.1 s IMU gap is a stale IMU, and
    the emulator, which sends every sensor, late by that much leaves that gap);
    ``FREEZE_MS`` when no source went stale."""
    timeouts_ms = [1000.0 * float(timeout_s) for *_, timeout_s in STALE_LINE.findall(drive_log)]
    return min(timeouts_ms, default=FREEZE_MS)


def _stale(source: str, age_s: float, seen_s: float, timeout_s: float) -> str:
    """drive's log line when ``source`` turns stale (the format ``STALE_LINE`` reads)."""
    return (f"WARNING sensors.manager: {source} stale: last reading {age_s:.3f} s ago; its "
            f"reader proved {seen_s:.3f} s of silence (timeout {timeout_s:.3f} s) and was "
            f"last back {age_s - seen_s:.3f} s ago")


def test_stack_froze_ms_reads_a_starved_reader_not_a_silent_sensor() -> None:
    starved = _stale("imu", 1.010, 0.000, 0.100)
    silent = _stale("gps", 0.700, 0.650, 0.500)
    assert stack_froze_ms(starved + "\n" + silent) == pytest.approx(1010.0)
    assert stack_froze_ms(silent) == 0.0
    assert stack_froze_ms("") == 0.0


def test_freeze_needed_ms_is_the_stale_sources_timeout() -> None:
    imu = _stale("imu", 0.129, 0.105, 0.100)
    lidar = _stale("lidar", 0.359, 0.303, 0.300)
    assert freeze_needed_ms(lidar + "\n" + imu) == pytest.approx(100.0)
    assert freeze_needed_ms(lidar) == pytest.approx(300.0)
    assert freeze_needed_ms("WARNING controller.safety: stop (emergency): RES") == FREEZE_MS


def _safe_stop_after_a_freeze(emulator: Proc, drive: Proc, emulator_summary: Path) -> str:
    """The stack did not drive after the go. That is allowed, once, only when the machine
    froze for longer than the timeout of a sensor drive found stale (``freeze_needed_ms``): the
    emulator, which sends every sensor, measured it of its own steps, or drive's receiver
    threads were kept from running that long while their sensors kept sending (the drive
    process starved); and the stack stopped safely (no cone hit, drive's own stop). Returns
    what happened, for the log."""
    logs = f"drive:\n{drive.log()[-3000:]}"
    assert drive.wait(60.0) == 0, logs
    assert emulator.wait(60.0) == 0, emulator.log()
    served = json.loads(emulator_summary.read_text())
    summary_path = emulator_summary.parent / "drive" / "summary.json"
    stop = json.loads(summary_path.read_text())["stop_reason"]
    readers_ms = stack_froze_ms(drive.log())
    froze_ms = max(float(served["step_late_max_ms"]), readers_ms)
    needed_ms = freeze_needed_ms(drive.log())
    assert froze_ms >= needed_ms, (f"the stack did not drive after the go, and the machine "
                                   f"did not freeze for {needed_ms:.0f} ms (emulator late "
                                   f"{served['step_late_max_ms']} ms, drive's readers "
                                   f"{readers_ms:.0f} ms)\n{logs}")
    assert served["cones_hit"] == 0, served
    assert served["as_state"] == "EMERGENCY", (stop, served)  # the stack's controlled stop
    return f"machine froze {froze_ms:.0f} ms; drive stopped safely: {stop}"


@pytest.mark.slow
def test_emulated_run_and_kill(tmp_path: Path, procs: list[Proc]) -> None:
    emulator, drive, emulator_summary, handover_s, drove = _session(tmp_path / "run1", procs)
    if not drove:
        print(f"\nfirst session: {_safe_stop_after_a_freeze(emulator, drive, emulator_summary)}"
              "; running it again")
        emulator, drive, emulator_summary, handover_s, drove = _session(tmp_path / "run2",
                                                                         procs)
        assert drove, f"the stack did not drive after the go\ndrive:\n{drive.log()[-3000:]}"
    drive_dir = emulator_summary.parent / "drive"
    assert drive.popen.poll() is None, f"drive ended by itself:\n{drive.log()[-3000:]}"
    drive.popen.send_signal(signal.SIGKILL)
    drive.wait(10.0)
    # The emulator's watchdog brakes the car; it ends once the car stood with no frames.
    assert emulator.wait(40.0) == 0, emulator.log()
    served = json.loads(emulator_summary.read_text())
    print(f"\nemulator: {json.dumps(served)}")

    assert served["exploration_lap_time_s"] is not None
    assert served["handover_time_s"] == pytest.approx(handover_s, abs=0.01)
    assert served["stop_reason"] == "actuator frames stopped; car at standstill"
    assert served["final_speed_mps"] < 0.05
    watchdog = served["watchdog_stop"]
    assert watchdog is not None
    assert watchdog["time_s"] > handover_s  # the kill, not an earlier hiccup
    assert watchdog["time_s"] - watchdog["last_frame_s"] <= 0.25
    assert watchdog["speed_mps"] > 1.0  # it was driving when drive died
    assert watchdog["stop_time_s"] < watchdog["speed_mps"] / 5.0 + 0.5
    assert served["non_command_frames_in"] == 0
    assert served["can_bad_lines"] == 0

    # What drive recorded (up to its last complete chunk).
    times, states, health = read_drive_recording(drive_dir / "recording.mcap")
    assert AsState.DRIVING in states, "drive never commanded DRIVING: the RES go did not reach it"
    seen = [t["state"] for t in served["as_transitions"]]
    assert seen[:3] == ["OFF", "READY", "DRIVING"], seen  # AS_STATUS, as the car decoded it
    assert health, "no /health recorded"
    last = health[-1]
    rates = {s.source: s.rate_hz for s in last.sources}
    for source in SOURCES:
        assert rates.get(source, 0.0) > 0.0, (source, rates)
    periods_ms = np.diff(times) * 1e3
    p50, p99 = np.percentile(periods_ms, [50, 99])
    print(f"drive control period over {periods_ms.size} ticks (mapping on): p50 {p50:.3f} ms, "
          f"p99 {p99:.3f} ms, max {periods_ms.max():.1f} ms (target 10 ms)")
    assert math.isclose(p50, 10.0, abs_tol=0.5)
    assert p99 < 30.0  # gross check only: the 2 ms target is reported, not asserted here

    print(f"autonomous laps {served['laps_completed']} {served['lap_times_s']}, "
          f"cones hit {served['cones_hit']}, off track {served['off_track']}")
    assert served["cones_hit"] == 0 and served["off_track"] == 0
    assert served["cones_hit"] == 0
