"""Fast end-to-end smoke tests of ``main.py``: ``--help`` lists only subcommands that exist, a
bad argument gives one clear line, and ``sim --fault estop@T`` stops the car and reports it."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from support.shared_data import shared_data

ROOT = Path(__file__).resolve().parents[1]
OVAL = ROOT.parent / "shared" / "data" / "tracks" / "eufs" / "small_oval.csv"


def main_py(*args: str, timeout_s: float = 120.0) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "main.py", *args], cwd=ROOT, capture_output=True,
                          text=True, timeout=timeout_s, check=False)


def runnable(parser: Any) -> bool:
    """A subcommand runs something: it sets ``func``, or each of its own subcommands does."""
    if parser.get_default("func") is not None:
        return True
    inner = parser._subparsers
    if inner is None:
        return False
    subs = inner._group_actions[0].choices
    return bool(subs) and all(runnable(sub) for sub in subs.values())


def test_help_lists_only_existing_subcommands() -> None:
    sys.path.insert(0, str(ROOT))
    import main

    parser = main.build_parser()
    choices: Any = parser._subparsers._group_actions[0].choices  # type: ignore[union-attr]
    proc = main_py("--help")
    assert proc.returncode == 0, proc.stderr
    listed = re.findall(r"^    (\w+)\s", proc.stdout, flags=re.MULTILINE)
    assert listed, proc.stdout
    assert set(listed) == set(choices)
    for name in ("sim", "replay", "info", "drive", "record", "emulate", "bench", "config"):
        assert name in listed, name
    for name in listed:
        assert runnable(choices[name]), f"'{name}' is listed but runs nothing"
    bench = choices["bench"]._subparsers._group_actions[0].choices
    assert "replay" in bench
    for module in bench:
        assert (ROOT / "bench" / f"bench_{module}.py").exists()


def test_bad_arguments_give_one_clear_line(tmp_path: Path) -> None:
    proc = main_py("sim", "--fault", "bogus@1", "--no-render", "--out", str(tmp_path / "x"))
    assert proc.returncode == 2
    assert "Traceback" not in proc.stderr
    assert "bogus" in proc.stderr and "estop" in proc.stderr  # says what is expected
    proc = main_py("replay", str(tmp_path / "missing.mcap"))
    assert proc.returncode == 2
    assert "Traceback" not in proc.stderr and "missing.mcap" in proc.stderr


@pytest.mark.slow
def test_sim_estop_while_driving(tmp_path: Path) -> None:
    """On the small oval the exploration lap ends ~16 s and the RES go comes ~19 s; an e-stop
    at 24 s hits the car while the stack drives it. Sensor faults earlier in the run (CAN
    garbage, IMU NaNs, a GPS dropout) must not crash anything, and the replay of the run's
    recording reproduces it."""
    shared_data("tracks", "eufs", "small_oval.csv")
    config = tmp_path / "c.toml"
    config.write_text("[run]\nmax_sim_time_s = 40.0\nrender = false\n")
    out = tmp_path / "run"
    proc = main_py("sim", "--config", str(config), "--track", str(OVAL), "--no-render",
                   "--exploration", "manual", "--fault", "estop@24",
                   "--fault", "can-garbage@5:3", "--fault", "imu-nan@8:1",
                   "--fault", "gps-dropout@2:5", "--out", str(out), "--json")
    assert proc.returncode == 0, proc.stderr
    summary: dict[str, Any] = json.loads((out / "summary.json").read_text())
    assert summary["stop_reason"] != "timeout"
    assert summary["finished"] is False
    # The exploration lap was over and the stack drove the car when the e-stop came.
    assert summary["exploration_lap_time_s"] is not None
    assert "emergency" in summary["stop_reason"], summary["stop_reason"]
    estop = summary["estop"]
    assert estop["time_s"] == pytest.approx(24.0, abs=0.02)
    assert estop["speed_mps"] > 0.0
    assert estop["stop_distance_m"] >= 0.0
    assert estop["stop_time_s"] > 0.0
    # The run ended once the car stood: shortly after the e-stop.
    assert summary["timing"]["sim_time_s"] < 24.0 + estop["stop_time_s"] + 0.5
    assert (out / "run_log.npz").exists()
    printed = json.loads(proc.stdout[proc.stdout.find("{"):])
    assert printed["outputs_sha256"] == summary["outputs_sha256"]
    # The faults are in the raw data: a replay reproduces the run, e-stop reaction included.
    replay = main_py("replay", str(out / "recording.mcap"), "--max", "--json")
    assert replay.returncode == 0, replay.stderr
    replayed = json.loads(replay.stdout[replay.stdout.find("{"):])
    assert replayed["outputs_sha256"] == summary["outputs_sha256"]
