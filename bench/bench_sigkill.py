"""What a SIGKILL of ``sim --realtime`` keeps, against the import floor (issue 19).

Each of ``--runs`` runs launches ``python main.py sim --realtime --laps 2 --no-render`` (with the
bench's ``--config``) in a temporary folder, kills it with SIGKILL ``--after`` seconds (default
8) after the launch, waits for its recorder's process to finish the file, and reads the
recording's ``duration_s`` as ``info`` does. What the file lacks of the ``--after`` seconds is
the run's start-up before its first tick (plus at most the recorder link's 0.05 s).

The reference, measured in the same run: the **import floor**, the wall time of a bare
interpreter importing the third-party modules that ``sim`` imports before its first tick (listed
by a child that imports the sim's modules), the median of ``--runs`` tries. A start-up as short
as the imports allow has ``startup_over_floor`` near 1. It also says whether our modules have a
bytecode cache (without one, as with ``PYTHONDONTWRITEBYTECODE`` set and a fresh checkout, every
start compiles them: about 0.4 s on the 2-core machine).

Last line: ``duration_s_min=<x> duration_s_median=<x> startup_s_median=<x> import_floor_s=<x>
startup_over_floor=<x>``.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import os
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from common.cli_types import positive_float, positive_int
from orchestrator.config import AppConfig

HELP = "SIGKILL sim --realtime N s after launch: seconds recorded, start-up vs import floor"

ROOT = Path(__file__).resolve().parents[1]
GROUP_END_TIMEOUT_S = 60.0
"""Longest wait (s) for the killed run's recorder's process to finish the file and end."""

_LIST_THIRD_PARTY = """
import json, sys, sysconfig
sys.path.insert(0, sys.argv[1])
import main, orchestrator.sim
roots = {sysconfig.get_paths()["purelib"], sysconfig.get_paths()["platlib"]}
names = [name for name, module in list(sys.modules.items())
         if any(str(getattr(module, "__file__", None) or "").startswith(root) for root in roots)]
print(json.dumps(names))
"""

_IMPORT_ALL = """
import importlib, json, sys
failed = 0
for name in json.loads(sys.stdin.read()):
    try:
        importlib.import_module(name)
    except Exception:
        failed += 1
print(failed)
"""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``bench sigkill``."""
    parser.add_argument("--runs", type=positive_int, default=5, help="kills (default 5)")
    parser.add_argument("--after", type=positive_float, default=8.0,
                        help="seconds from launch to SIGKILL (default 8, the issue's)")


def third_party_modules() -> list[str]:
    """The installed (site-packages) modules ``sim`` has imported before its run, in import
    order: what a bare interpreter imports to measure the floor."""
    out = subprocess.run([sys.executable, "-c", _LIST_THIRD_PARTY, str(ROOT)], cwd=ROOT,
                         capture_output=True, text=True, check=True)
    names: list[str] = json.loads(out.stdout)
    return names


def import_floor_s(modules: list[str]) -> tuple[float, int]:
    """Wall time (s) of a bare interpreter importing ``modules``, and how many failed."""
    t0 = time.perf_counter()
    out = subprocess.run([sys.executable, "-c", _IMPORT_ALL], cwd=ROOT, input=json.dumps(modules),
                         capture_output=True, text=True, check=True)
    return time.perf_counter() - t0, int(out.stdout.strip())


def bytecode_cached() -> bool:
    """Whether our modules have a fresh bytecode cache (``orchestrator/sim.py``'s stands in)."""
    source = ROOT / "orchestrator" / "sim.py"
    cached = Path(importlib.util.cache_from_source(str(source)))
    return cached.exists() and cached.stat().st_mtime >= source.stat().st_mtime


def wait_group_gone(pgid: int, timeout_s: float) -> bool:
    """Whether process group ``pgid`` (a killed run and its recorder's process) ended within
    ``timeout_s``."""
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        try:
            os.killpg(pgid, 0)
        except ProcessLookupError:
            return True
        time.sleep(0.05)
    return False


def kill_after(after_s: float, out_dir: Path, config_file: str | None = None) -> float:
    """Launch ``sim --realtime`` (with ``config_file``), SIGKILL it ``after_s`` after the
    launch, let its recorder's process finish the file; the recording's ``duration_s``."""
    from recordings.info import info

    t0 = time.monotonic()
    proc = subprocess.Popen(
        [sys.executable, "main.py", "sim", "--realtime", "--laps", "2", "--no-render",
         "--out", str(out_dir), *(["--config", config_file] if config_file else [])],
        cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
    time.sleep(max(0.0, t0 + after_s - time.monotonic()))
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    if not wait_group_gone(proc.pid, GROUP_END_TIMEOUT_S):
        os.killpg(proc.pid, signal.SIGKILL)
        raise RuntimeError("the recorder's process did not end after its run was killed")
    return float(info(out_dir / "recording.mcap")["duration_s"])


def run(args: argparse.Namespace, config: AppConfig) -> int:
    """The kills, then the floor; the last line has the figures."""
    modules = third_party_modules()
    cached = bytecode_cached()
    print(f"{args.runs} kills of sim --realtime {args.after:g} s after launch; bytecode cache "
          f"of our modules: {'yes' if cached else 'no'}", flush=True)
    durations: list[float] = []
    with tempfile.TemporaryDirectory(prefix="bench_sigkill_") as tmp:
        for k in range(1, args.runs + 1):
            duration_s = kill_after(args.after, Path(tmp) / f"run_{k}", args.config)
            durations.append(duration_s)
            print(f"run {k}: {duration_s:.2f} s recorded, start-up {args.after - duration_s:.2f} s",
                  flush=True)
    tries = [import_floor_s(modules) for _ in range(args.runs)]
    floors = [floor for floor, _ in tries]
    floor_s = statistics.median(floors)
    print(f"import floor: {len(modules)} third-party modules in {floor_s:.2f} s (median of "
          f"{len(floors)}; {min(floors):.2f}-{max(floors):.2f} s), "
          f"{max(failed for _, failed in tries)} failed to import")
    median_s = statistics.median(durations)
    startup_s = args.after - median_s
    print(f"duration_s_min={min(durations):.2f} duration_s_median={median_s:.2f} "
          f"startup_s_median={startup_s:.2f} import_floor_s={floor_s:.2f} "
          f"startup_over_floor={startup_s / floor_s:.2f}")
    return 0
