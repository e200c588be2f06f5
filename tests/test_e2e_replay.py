"""End to end: a short ``main.py sim`` run replayed with ``--max`` and ``--rate 4`` gives the
sim's own ``outputs_sha256`` (issue 5, determinism), driven through ``main.py`` itself.

The run is on the small EUFS oval (exploration lap ~16 s), long enough to include the handover
(RES go) and the stack's own driving, so plans and commands of the autonomous phase are in the
hash, and with ``--laps 1`` so that the replay must take the run's configuration from the
recording. What the stack does on the track is not tested here.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from support.shared_data import shared_data

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT.parent / "shared" / "data"
TRACK = DATA / "tracks" / "eufs" / "small_oval.csv"
SIM_TIME_S = 26.0


def main_py(*args: str, timeout_s: float = 120.0) -> subprocess.CompletedProcess[str]:
    """Run ``python main.py ARGS`` from the project root; the completed process."""
    env = dict(os.environ, PYTHONHASHSEED="0")
    return subprocess.run(
        [sys.executable, "main.py", *args], cwd=ROOT, env=env, capture_output=True, text=True,
        timeout=timeout_s, check=False,
    )


def json_out(proc: subprocess.CompletedProcess[str]) -> dict[str, Any]:
    """The JSON document a ``--json`` command printed on stdout."""
    text = proc.stdout
    start = text.find("{")
    assert start >= 0, f"no JSON on stdout:\n{text}\nstderr:\n{proc.stderr}"
    result: dict[str, Any] = json.loads(text[start:])
    return result


@pytest.fixture(scope="module")
def sim_run(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict[str, Any]]:
    shared_data("tracks", "eufs", "small_oval.csv")
    out = tmp_path_factory.mktemp("e2e_sim")
    config = out / "short.toml"
    config.write_text(f"[run]\nmax_sim_time_s = {SIM_TIME_S}\nrender = false\n")
    proc = main_py("sim", "--config", str(config), "--track", str(TRACK), "--laps", "1",
                   "--exploration", "manual",  # a person's lap, then the handover
                   "--no-render", "--out", str(out / "run"), "--json")
    assert proc.returncode in (0, 1), proc.stderr  # 1: the run timed out (expected here)
    summary = json_out(proc)
    on_disk = json.loads((out / "run" / "summary.json").read_text())
    assert on_disk["outputs_sha256"] == summary["outputs_sha256"]
    return out / "run" / "recording.mcap", on_disk


@pytest.mark.slow
def test_sim_run_reaches_autonomous_phase(sim_run: tuple[Path, dict[str, Any]]) -> None:
    recording, summary = sim_run
    assert len(summary["outputs_sha256"]) == 64
    assert summary["timing"]["sim_time_s"] == pytest.approx(SIM_TIME_S, abs=0.02)
    proc = main_py("info", str(recording), "--json")
    assert proc.returncode == 0, proc.stderr
    info = json_out(proc)
    assert not info["recovered"]
    assert "config_toml" in info["metadata"]["fsd"]
    counts = summary["recording"]  # the run waits for its recorder: nothing dropped
    assert counts["dropped"] == 0 and counts["errors"] == 0
    assert counts["written"] == info["message_count"]
    # The stack planned (after loop closure or the RES go), so the hash covers driving too.
    assert info["topics"]["/plan"]["count"] > 10
    assert info["topics"]["/command"]["count"] == pytest.approx(SIM_TIME_S * 100, abs=2)


@pytest.mark.parametrize("pace", [["--max"], ["--rate", "4"]], ids=["max", "rate4"])
@pytest.mark.slow
def test_replay_reproduces_sim_outputs(sim_run: tuple[Path, dict[str, Any]],
                                       pace: list[str], tmp_path: Path) -> None:
    recording, summary = sim_run
    proc = main_py("replay", str(recording), *pace, "--json", "--out", str(tmp_path))
    assert proc.returncode == 0, proc.stderr
    replay = json_out(proc)
    assert replay["ticks"] == round(SIM_TIME_S * 100)
    assert replay["outputs_sha256"] == summary["outputs_sha256"], (
        f"replay {pace} diverged from the sim run"
    )
    assert json.loads((tmp_path / "summary.json").read_text())["outputs_sha256"] == (
        summary["outputs_sha256"]
    )
    if pace == ["--rate", "4"]:
        # Paced on the recording's clock: 26 s at 4x takes at least 6.5 s of wall time.
        assert replay["timing"]["wall_time_s"] >= SIM_TIME_S / 4 - 0.1
    assert "pose_rmse_m" in replay  # the recording has ground truth


def test_front_end_process_changes_nothing(sim_run: tuple[Path, dict[str, Any]]) -> None:
    """The replay's front end (reading + Sensor Manager) run in its own process hands Main the
    same ticks as run in Main's process: equal readings and health, tick by tick."""
    from orchestrator.config import AppConfig
    from orchestrator.replay import last_command_time_s, replay_config
    from orchestrator.replay_front import tick_inputs, tick_inputs_in_process

    recording, _summary = sim_run
    config = replay_config(AppConfig(), recording, None)
    n_ticks = round(last_command_time_s(recording) * config.run.control_rate_hz)
    n_ticks = min(n_ticks, 800)  # 8 s: GPS, IMU, CAN, LiDAR sweeps and camera frames
    here = list(tick_inputs(config, recording, None, n_ticks))
    beside = list(tick_inputs_in_process(config, recording, None, n_ticks))
    assert len(here) == len(beside) == n_ticks
    readings = 0
    for a, b in zip(here, beside, strict=True):
        assert a.t_s == b.t_s
        assert a.health == b.health
        assert len(a.readings) == len(b.readings)
        for ra, rb in zip(a.readings, b.readings, strict=True):
            assert type(ra) is type(rb) and ra.timestamp_s == rb.timestamp_s
        readings += len(a.readings)
        assert [t for t, _ in a.truth] == [t for t, _ in b.truth]
    assert readings > n_ticks  # IMU alone is 200 Hz


def test_front_end_failure_is_a_clear_error(sim_run: tuple[Path, dict[str, Any]],
                                            monkeypatch: pytest.MonkeyPatch) -> None:
    """A failure inside the front-end process ends the replay with a RecordingError naming
    it, not with a hang or a silent short replay."""
    from common.errors import RecordingError
    from orchestrator.config import AppConfig
    from orchestrator.replay import ReplayOptions, run_replay
    from sensors.manager import SensorManager

    recording, _summary = sim_run

    def broken_health(self: SensorManager, now_s: float) -> None:
        if now_s > 2.0:
            raise RuntimeError("health exploded")

    monkeypatch.setattr(SensorManager, "health", broken_health)
    with pytest.raises(RecordingError, match="front end failed: RuntimeError: health exploded"):
        run_replay(AppConfig(), ReplayOptions(recording))
