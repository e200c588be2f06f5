"""The sample recording: one simulated exploration lap, made on first use.

``python main.py replay sample`` replays it, so that replay works on a fresh machine with no
recording of one's own. It is not kept in git (about 20 MB of LiDAR packets): the first call of
:func:`sample_recording_path` simulates the exploration lap on the built-in default track (the
scripted driver's lap, a stop past the start line, up to the RES "go"), which takes some
seconds, and later calls return the file. The run's configuration is stored in the recording,
so its replay reproduces the run's outputs (``outputs_sha256``) whatever the local config.
"""

from __future__ import annotations

import logging
import os
import shutil
import tempfile
import time
from pathlib import Path
from typing import Any

log = logging.getLogger(__name__)

SAMPLE_NAME = "exploration_lap.mcap"
SAMPLE_WORD = "sample"
"""What ``replay`` takes in place of a path to mean the sample recording."""
SAMPLE_TRACK = "default"
SAMPLE_SEED = 1
SAMPLE_MAX_BYTES = 20_000_000
SAMPLE_MAX_SIM_TIME_S = 120.0
"""A limit for the simulation that makes the sample (its lap ends at the handover, ~50 s)."""


SAMPLES_DIR_ENV = "FSD_SAMPLES_DIR"
"""Environment variable naming another folder for the sample (tests, read-only installs)."""


def samples_dir() -> Path:
    """``orchestrator/samples/`` in the project (or a user cache folder if that is read-only;
    or ``$FSD_SAMPLES_DIR``)."""
    override = os.environ.get(SAMPLES_DIR_ENV)
    if override:
        folder = Path(override)
        folder.mkdir(parents=True, exist_ok=True)
        return folder
    here = Path(__file__).resolve().parent / "samples"
    try:
        here.mkdir(parents=True, exist_ok=True)
        if os.access(here, os.W_OK) or (here / SAMPLE_NAME).exists():
            return here
    except OSError:
        pass
    cache = Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache")) / "fsd-stack" / "samples"
    cache.mkdir(parents=True, exist_ok=True)
    return cache


def sample_recording_path(make: bool = True) -> Path:
    """The sample recording (``orchestrator/samples/exploration_lap.mcap``); made if absent and
    ``make`` is true (a simulation of some seconds, logged)."""
    path = samples_dir() / SAMPLE_NAME
    if path.exists() or not make:
        return path
    make_sample(path)
    return path


def make_sample(path: Path, max_sim_time_s: float = SAMPLE_MAX_SIM_TIME_S) -> dict[str, Any]:
    """Simulate the exploration lap and write its recording to ``path`` (atomically: a half-made
    sample is never seen, and two processes making it at once both end with a whole file).
    Returns the run's summary (also written next to it: :func:`summary_path`)."""
    from orchestrator.config import AppConfig
    from orchestrator.sim import SimOptions, run_sim

    log.warning("no sample recording at %s: simulating one exploration lap to make it "
                "(once; about 20 s)", path)
    start = time.perf_counter()
    config = AppConfig()
    config.mission.exploration = "manual"  # the sample is a person's exploration lap
    config.run.max_sim_time_s = max_sim_time_s
    path.parent.mkdir(parents=True, exist_ok=True)
    work = Path(tempfile.mkdtemp(prefix=".making-", dir=path.parent))
    try:
        summary = run_sim(config, SimOptions(
            track=SAMPLE_TRACK, seed=SAMPLE_SEED, out_dir=work, render=False, record=True,
            end_at_handover=True,
        ))
        made = work / "recording.mcap"
        size = made.stat().st_size
        if summary["stop_reason"] != "handover":
            log.warning("the sample run ended with %r before the handover; kept as it is",
                        summary["stop_reason"])
        if size > SAMPLE_MAX_BYTES:
            log.warning("the sample recording is %.1f MB (over %.0f MB)", size / 1e6,
                        SAMPLE_MAX_BYTES / 1e6)
        (work / "summary.json").replace(summary_path(path))
        os.replace(made, path)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    log.warning("sample recording made: %s (%.1f MB, %.1f s of driving, in %.1f s)", path,
                size / 1e6, summary["timing"]["sim_time_s"],
                time.perf_counter() - start)
    return summary


def summary_path(path: Path) -> Path:
    """The ``summary.json`` of the run that made the sample at ``path`` (its outputs_sha256)."""
    return path.with_suffix(".summary.json")


def resolve_recording(name: str | os.PathLike[str]) -> Path:
    """A recording path as given, or the sample recording for the word ``sample`` (when no file
    of that name exists)."""
    path = Path(name)
    if str(name) == SAMPLE_WORD and not path.exists():
        return sample_recording_path()
    return path
