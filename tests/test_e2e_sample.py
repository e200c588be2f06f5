"""The sample recording (issue 5, item 7): made on first use, then ``main.py replay sample``
replays it and reproduces the run that made it.

The real sample is one exploration lap of the default track (~46 s of driving, ~20 s to make);
here a 3-second one is made in a temporary folder (``$FSD_SAMPLES_DIR``) to test the machinery.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from orchestrator import sample

ROOT = Path(__file__).resolve().parents[1]


def test_resolve_recording(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(sample.SAMPLES_DIR_ENV, str(tmp_path / "samples"))
    assert sample.resolve_recording("x.mcap") == Path("x.mcap")
    expected = tmp_path / "samples" / sample.SAMPLE_NAME
    assert sample.sample_recording_path(make=False) == expected
    assert not expected.exists()
    monkeypatch.chdir(tmp_path)
    (tmp_path / "sample").write_bytes(b"")  # a file really called 'sample' wins
    assert sample.resolve_recording("sample") == Path("sample")


def test_sample_made_on_first_use_and_replayed(tmp_path: Path,
                                                monkeypatch: pytest.MonkeyPatch) -> None:
    folder = tmp_path / "samples"
    monkeypatch.setenv(sample.SAMPLES_DIR_ENV, str(folder))
    path = folder / sample.SAMPLE_NAME
    made = sample.make_sample(path, max_sim_time_s=3.0)
    assert path.exists()
    assert [p.name for p in folder.iterdir() if p.name.startswith(".making-")] == []
    recorded = json.loads(sample.summary_path(path).read_text())
    assert recorded["outputs_sha256"] == made["outputs_sha256"]
    assert sample.sample_recording_path() == path  # made already: not made again

    env = dict(os.environ, **{sample.SAMPLES_DIR_ENV: str(folder)})
    proc = subprocess.run([sys.executable, "main.py", "replay", "sample", "--max", "--json"],
                          cwd=ROOT, env=env, capture_output=True, text=True, timeout=120,
                          check=False)
    assert proc.returncode == 0, proc.stderr
    replay = json.loads(proc.stdout[proc.stdout.find("{"):])
    assert replay["recording"] == str(path)
    assert replay["ticks"] == 300
    assert replay["outputs_sha256"] == recorded["outputs_sha256"]
