"""The car's loop on a busy machine: the emulate + drive pair while busy processes hold the cores.

Starts ``--busy`` processes (default 2) that spin, then ``emulate`` on small_track (the car over
real transports: pseudo-terminals, a CAN bus, UDP loopback) and ``drive --laps N`` against it, as
``tests/test_e2e_emulate.py`` does. The CAN bus (``--can``) is by default python-can's
``udp_multicast``: kernel sockets, as the car's SocketCAN (this machine may have no ``vcan``).
``--can slcan`` puts an slcan adapter on a pseudo-terminal instead, a USB adapter's path: on a
machine whose cores are all busy, Linux's tty worker (normal priority) then holds frames for
0.2-0.5 s at times, and the emulated car's 200 ms watchdog brakes (issue 19). drive runs as on
the car, its control loop at its default real-time priority (without the privilege it says so
and runs without). The emulator stands in for the car's own hardware, which has processors of
its own; here it shares the cores, so it runs at real-time priority ``EMULATOR_RT_PRIORITY``,
below drive's control loop, and the busy processes cannot make the stand-in sensors late. When
drive ends (or after ``--seconds``) it prints laps, cones hit (the emulated world's count), the
control period p99 against its target, how late the control loop woke, the CAN commands sent,
failed and superseded and how long they waited for the bus, the plan and map age p99 at the
control loop, how late the emulator sent its units (its steps' lateness: a stand-in sensor late
by more than a timeout is the test machine's, not the stack's), each process's major page
faults, and the stop reason. ``--runs N`` runs N pairs one after another (one run says little
on a loaded machine) and counts the clean ones; last line
``control_p99_over_period_ms=<worst x> laps=<fewest> cones_hit=<most> clean=<k>/<N>``.
``--serial-stall T:D`` has the emulator hold its GPS and IMU bytes from T for D seconds, then
write them at once: a stalled serial link (issue 19 saw 0.46 s at 15.6 m/s under load); drive's
readers see the silence, so a stall longer than the IMU's timeout ends in a stop.
``--keep DIR`` keeps each run's folder (drive's recording, summary and log on stderr, the
emulator's summary) as ``DIR/run_<k>`` to study a run that was not clean.
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from common.cli_types import non_negative_int, positive_float, positive_int, stall_window
from orchestrator.config import AppConfig

HELP = "emulate + drive on small_track while busy processes load the cores: laps, p99s, stop"
EMULATOR_RT_PRIORITY = 5
"""SCHED_FIFO priority of the emulator: below drive's control loop (10 by default)."""

ROOT = Path(__file__).resolve().parents[1]
TRACK = ROOT.parent / "shared" / "data" / "tracks" / "eufs" / "small_track.csv"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``bench load``."""
    parser.add_argument("--busy", type=non_negative_int, default=2,
                        help="busy processes beside the pair (default 2)")
    parser.add_argument("--laps", type=positive_int, default=2, help="autonomous laps (2)")
    parser.add_argument("--seconds", type=positive_float, default=150.0,
                        help="longest the emulator runs (s, default 150)")
    parser.add_argument("--track", default=str(TRACK), help="track (default small_track)")
    parser.add_argument("--can", choices=("udp", "slcan"), default="udp",
                        help="the emulated car's CAN bus: udp_multicast (kernel sockets, as "
                             "SocketCAN; default) or an slcan adapter on a pseudo-terminal")
    parser.add_argument("--runs", type=positive_int, default=1,
                        help="pairs run one after another (default 1); prints the clean count")
    parser.add_argument("--serial-stall", type=stall_window, action="append", default=[],
                        metavar="T:D",
                        help="the emulator holds the GPS and IMU bytes from T for D s of its "
                             "clock, then writes them at once (emulate --serial-stall)")
    parser.add_argument("--keep", type=Path, default=None, metavar="DIR",
                        help="keep each run's folder (drive's recording and log, the "
                             "emulator's summary) as DIR/run_<k>; by default they are removed")


def _spin() -> None:
    while True:
        pass


def _start(args: list[str], folder: Path, name: str) -> subprocess.Popen[bytes]:
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    return subprocess.Popen([sys.executable, "main.py", *args], cwd=ROOT, env=env,
                            stdout=(folder / f"{name}.out").open("wb"),
                            stderr=(folder / f"{name}.err").open("wb"))


def run(args: argparse.Namespace, config: AppConfig) -> int:
    """Run the pair under load ``--runs`` times and print each run's figures, then the count
    of clean runs (2 laps, 0 cones, no stop but the finish)."""
    del config
    if args.keep is not None:
        taken = [f"run_{k + 1}" for k in range(args.runs) if (args.keep / f"run_{k + 1}").exists()]
        if taken:
            raise SystemExit(f"bench load: --keep {args.keep} already holds {', '.join(taken)}: "
                             f"give a new folder")
    busy = [multiprocessing.Process(target=_spin, daemon=True) for _ in range(args.busy)]
    for proc in busy:
        proc.start()
    over_ms: list[float] = []
    laps: list[int] = []
    cones: list[int] = []
    clean = 0
    try:
        for k in range(args.runs):
            if args.keep is not None:
                folder = args.keep / f"run_{k + 1}"
                folder.mkdir(parents=True, exist_ok=False)
                result = _pair(folder, args)
            else:
                with tempfile.TemporaryDirectory(prefix="bench_load_") as tmp:
                    result = _pair(Path(tmp), args)
            if args.runs > 1:
                print(f"--- run {k + 1} of {args.runs}")
            run_over_ms, run_laps, run_cones, run_clean = _report(result, args)
            over_ms.append(run_over_ms)
            laps.append(run_laps)
            cones.append(run_cones)
            clean += run_clean
    finally:
        for proc in busy:
            proc.terminate()
    if args.runs > 1:
        print(f"clean runs          {clean} of {args.runs} ({args.laps} laps, 0 cones, no stop)")
    print(f"control_p99_over_period_ms={max(over_ms):.2f} laps={min(laps)} "
          f"cones_hit={max(cones)} clean={clean}/{args.runs}")
    return 0


def _report(result: dict[str, Any], args: argparse.Namespace) -> tuple[float, int, int, bool]:
    """Print one run's figures; return (control p99 over its period in ms, laps, cones hit,
    clean)."""
    timing = result["drive"].get("timing", {})
    target = float(timing.get("control_period_target_ms", float("nan")))
    p99 = float(timing.get("control_period_p99_ms", float("nan")))
    print(f"busy processes      {args.busy}")
    print(f"CAN bus             {args.can}")
    print(f"laps                {result['drive'].get('laps_completed')}")
    print(f"cones hit           {result['emulator'].get('cones_hit')} (at "
          f"{result['emulator'].get('cone_hit_times_s')} s of the emulator's clock)")
    print(f"control period p99  {p99:.2f} ms (target {target:.2f} ms)")
    print(f"control wake late   p99 {timing.get('control_wake_late_p99_ms')} ms, period max "
          f"{timing.get('control_period_max_ms')} ms")
    can_send = timing.get("can_send", {})
    print(f"CAN commands        {can_send.get('sent')} sent, {can_send.get('errors')} failed, "
          f"{can_send.get('superseded')} superseded; waited p99 {can_send.get('lag_p99_ms')} "
          f"ms, max {can_send.get('lag_max_ms')} ms (the control loop never waits)")
    print(f"plan age p99        {timing.get('plan_age_p99_ms')} ms")
    print(f"map age p99         {timing.get('map_age_p99_ms')} ms")
    emulator = result["emulator"]
    print(f"emulator late       p99 {emulator.get('step_late_p99_ms')} ms, max "
          f"{emulator.get('step_late_max_ms')} ms, {emulator.get('steps_late')} steps over "
          f"100 ms (the stand-in sensors' own delay)")
    faults = timing.get("major_page_faults", {})
    print(f"major page faults   control {faults.get('control')}, executive "
          f"{faults.get('executive')}, emulator {emulator.get('major_page_faults')} (memory "
          f"locked: {timing.get('memory_locked')})")
    if args.serial_stall:
        print(f"serial stalls       {args.serial_stall} (s): "
              f"{emulator.get('serial_bytes_held')} GPS and IMU bytes held")
    print(f"stop reason         {result['drive'].get('stop_reason')}", flush=True)
    run_laps = int(result["drive"].get("laps_completed") or 0)
    run_cones = int(result["emulator"].get("cones_hit") or 0)
    stop = str(result["drive"].get("stop_reason", ""))
    clean = (run_laps >= args.laps and run_cones == 0 and stop.startswith("finished")
             and ";" not in stop)  # "finished: 2 laps; then stale sensor: ..." is a stop
    return p99 - target, run_laps, run_cones, clean


def _pair(folder: Path, args: argparse.Namespace) -> dict[str, Any]:
    car = folder / "car.toml"
    emulator_json = folder / "emulator.json"
    emulator = _start(["emulate", "--track", args.track, "--write-config", str(car),
                       "--summary", str(emulator_json), "--seconds", str(args.seconds),
                       "--workdir", str(folder / "ports"),
                       "--rt-priority", str(EMULATOR_RT_PRIORITY),
                       "--can", args.can,
                       *[f"--serial-stall={t:g}:{d:g}" for t, d in args.serial_stall]],
                      folder, "emulate")
    end = time.monotonic() + 60.0
    while not car.exists():
        if emulator.poll() is not None or time.monotonic() > end:
            raise SystemExit(f"bench load: emulate wrote no car config:\n"
                             f"{(folder / 'emulate.err').read_text(errors='replace')[-2000:]}")
        time.sleep(0.1)
    drive_dir = folder / "drive"
    drive = _start(["drive", "--config", str(car), "--laps", str(args.laps), "--out",
                    str(drive_dir)], folder, "drive")
    try:
        drive.wait(timeout=args.seconds + 30.0)
    except subprocess.TimeoutExpired:
        drive.terminate()
        drive.wait(timeout=30.0)
    emulator.terminate()
    try:
        emulator.wait(timeout=30.0)
    except subprocess.TimeoutExpired:
        emulator.kill()
    summary = drive_dir / "summary.json"
    drive_summary = json.loads(summary.read_text()) if summary.exists() else {
        "stop_reason": "no summary: " + (folder / "drive.err").read_text(errors="replace")[-500:]}
    emulator_summary = json.loads(emulator_json.read_text()) if emulator_json.exists() else {}
    return {"drive": drive_summary, "emulator": emulator_summary}
