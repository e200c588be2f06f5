"""One run of a campaign: what it is (:class:`RunSpec`), running it (:func:`run_one`, what a
Ray task executes) and its row in ``results.csv`` (:data:`COLUMNS`).

A run is the closed-loop ``sim`` with no rendering and no recording, exactly as
``python main.py sim --track T --seed S --laps N --no-render --no-record`` runs it alone (same
configuration, same options), so its ``outputs_sha256`` is the same. A run that raises is a row
with its ``error`` column filled, not the end of the campaign.
"""

from __future__ import annotations

import copy
import hashlib
import json
import logging
import math
import socket
import statistics
import tempfile
import time
import tomllib
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from common.config import apply_overrides
from common.errors import ConfigError
from orchestrator.config import AppConfig, validate

COLUMNS = (
    "run_id", "track", "seed", "fault", "setting", "mission", "laps",
    "finished", "stop_reason", "laps_completed", "best_lap_time_s", "mean_lap_time_s",
    "lap_times_s", "exploration_lap_time_s", "cones_hit", "off_track", "pose_rmse_m",
    "heading_rmse_rad", "map_rmse_m", "map_matched", "map_false_landmarks", "loop_closed",
    "sim_time_s", "realtime_factor", "outputs_sha256", "wall_s", "node", "error",
)
"""The columns of ``results.csv``, in order."""

NO_FAULT = "none"
NO_SETTING = "default"


@dataclass(frozen=True)
class RunSpec:
    """One (track, seed, fault, setting) combination."""

    track: str
    seed: int
    laps: int
    mission: str | None = None
    faults: tuple[str, ...] = ()
    """Fault specs (``KIND@T[:DURATION]``) injected together."""
    setting: tuple[tuple[str, Any], ...] = ()
    """Dotted config keys and their values (``planner.max_speed_mps``, 12.0)."""

    @property
    def fault_label(self) -> str:
        return "+".join(self.faults) if self.faults else NO_FAULT

    @property
    def setting_label(self) -> str:
        if not self.setting:
            return NO_SETTING
        return " ".join(f"{k}={json.dumps(v)}" for k, v in self.setting)

    @property
    def run_id(self) -> str:
        """A stable key of the run (what a resumed campaign skips)."""
        text = json.dumps([self.track, self.seed, self.laps, self.mission, list(self.faults),
                           [list(kv) for kv in self.setting]])
        return hashlib.sha256(text.encode()).hexdigest()[:16]

    def to_json(self) -> dict[str, Any]:
        return asdict(self)


def parse_value(text: str) -> Any:
    """A ``--set`` value as TOML reads it (``12``, ``0.5``, ``true``, ``"slam"``, ``[1, 2]``);
    a bare word that is not TOML is a string."""
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        return text


def parse_setting(pairs: list[str]) -> tuple[tuple[str, Any], ...]:
    """``["planner.max_speed_mps=12", ...]`` as ((key, value), ...); :class:`ConfigError` for a
    pair without ``=``."""
    setting = []
    for pair in pairs:
        key, eq, value = pair.partition("=")
        if not eq or not key.strip():
            raise ConfigError(f"--set {pair!r}: expected key=value, e.g. "
                              f"planner.max_speed_mps=12")
        setting.append((key.strip(), parse_value(value.strip())))
    return tuple(setting)


def nested(setting: tuple[tuple[str, Any], ...] | dict[str, Any]) -> dict[str, Any]:
    """Dotted keys as the nested tables of a TOML override."""
    items = setting.items() if isinstance(setting, dict) else setting
    out: dict[str, Any] = {}
    for key, value in items:
        *sections, leaf = key.split(".")
        table = out
        for section in sections:
            table = table.setdefault(section, {})
        table[leaf] = value
    return out


def configured(config: AppConfig, setting: tuple[tuple[str, Any], ...],
               source: str = "--set") -> AppConfig:
    """A copy of ``config`` with the setting applied and checked (:class:`ConfigError`, its
    line starting with ``source``)."""
    config = copy.deepcopy(config)
    apply_overrides(config, nested(setting), source)
    validate(config)
    return config


def run_one(config: AppConfig, spec: RunSpec) -> dict[str, Any]:
    """Run one closed-loop sim (no rendering, no recording, no plots) and return its row plus
    the full summary under ``"summary"`` (None when the run failed)."""
    from orchestrator.sim import SimOptions, run_sim

    root, progress = logging.getLogger(), logging.getLogger("progress")
    levels = root.level, progress.level
    root.setLevel(logging.ERROR)  # a run's warnings are many and not read; its row is the result
    progress.setLevel(logging.WARNING)
    wall0 = time.perf_counter()
    summary: dict[str, Any] | None = None
    error = ""
    try:
        run_config = configured(config, spec.setting)
        with tempfile.TemporaryDirectory(prefix="campaign_") as tmp:
            summary = run_sim(run_config, SimOptions(
                track=spec.track, laps=spec.laps, seed=spec.seed, mission=spec.mission,
                render=False, record=False, out_dir=Path(tmp), faults=list(spec.faults),
                artifacts=False))
        summary.pop("out_dir", None)
    except Exception as exc:  # a run that fails is a row, not the end of the campaign
        error = f"{type(exc).__name__}: {exc}".splitlines()[0]
    finally:
        root.setLevel(levels[0])
        progress.setLevel(levels[1])
    row = make_row(spec, summary, time.perf_counter() - wall0, error)
    row["summary"] = summary
    return row


def _num(value: Any, digits: int = 4) -> Any:
    if value is None:
        return ""
    if isinstance(value, float):
        return "" if not math.isfinite(value) else round(value, digits)
    return value


def make_row(spec: RunSpec, summary: dict[str, Any] | None, wall_s: float,
             error: str = "") -> dict[str, Any]:
    """The ``results.csv`` row of a run (every column of :data:`COLUMNS`)."""
    row: dict[str, Any] = {c: "" for c in COLUMNS}
    row.update(run_id=spec.run_id, track=spec.track, seed=spec.seed, fault=spec.fault_label,
               setting=spec.setting_label, mission=spec.mission or "", laps=spec.laps,
               wall_s=round(wall_s, 3), node=socket.gethostname(), error=error)
    if summary is None:
        return row
    laps = [float(t) for t in summary.get("lap_times_s", [])]
    map_eval = summary.get("map") or {}
    timing = summary.get("timing") or {}
    row.update(
        mission=summary.get("mission", row["mission"]),
        finished=summary.get("finished"),
        stop_reason=summary.get("stop_reason"),
        laps_completed=summary.get("laps_completed"),
        best_lap_time_s=_num(summary.get("best_lap_time_s")),
        mean_lap_time_s=_num(statistics.fmean(laps) if laps else None),
        lap_times_s=";".join(f"{t:.3f}" for t in laps),
        exploration_lap_time_s=_num(summary.get("exploration_lap_time_s")),
        cones_hit=summary.get("cones_hit"),
        off_track=summary.get("off_track"),
        pose_rmse_m=_num(summary.get("pose_rmse_m")),
        heading_rmse_rad=_num(summary.get("heading_rmse_rad"), 5),
        map_rmse_m=_num(map_eval.get("rmse_m")),
        map_matched=_num(map_eval.get("matched")),
        map_false_landmarks=_num(map_eval.get("false_landmarks")),
        loop_closed=(summary.get("loop_closure") or {}).get("closed"),
        sim_time_s=_num(timing.get("sim_time_s")),
        realtime_factor=_num(timing.get("realtime_factor"), 3),
        outputs_sha256=summary.get("outputs_sha256", ""),
    )
    return row


@dataclass
class RunRequest:
    """The combinations of a campaign: every track x seed x fault variant x setting."""

    tracks: list[str]
    seeds: list[int]
    laps: int
    mission: str | None = None
    faults: list[tuple[str, ...]] = field(default_factory=lambda: [()])
    settings: list[tuple[tuple[str, Any], ...]] = field(default_factory=lambda: [()])

    def specs(self) -> list[RunSpec]:
        return [RunSpec(track, seed, self.laps, self.mission, fault, setting)
                for setting in self.settings for fault in self.faults
                for track in self.tracks for seed in self.seeds]
