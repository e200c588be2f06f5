"""``tune``: Optuna's sampler proposes settings, a process pool or Ray runs each setting's runs.

Approach: Optuna's ask-and-tell interface in the driver, with a seeded TPE sampler, and the
campaign's runners for the runs (:mod:`scale.runners`: a process pool here, Ray tasks on a
cluster; one run per (track, seed) of a trial, as in a campaign). Trials go in batches: ask
``batch`` trials, run all their runs at once, tell the results in trial order. That keeps the
CPUs busy even when a trial has fewer runs than there are CPUs, and the study is reproducible
(the sampler sees the same history whichever run finishes first). Ray Tune
was not used: it schedules one trial per worker (a trial here is several runs) and brings its
own experiment folders and dependencies for nothing this needs.

Objective: the mean best lap (s) over the tracks and seeds; a run without a lap counts as
``run.max_sim_time_s``. Constraint (hard): no cone hit, no off-track event and no failed run,
given to the sampler as the trial's constraints (``Trial.set_constraint``, feasible when all
are <= 0); the best trial is the fastest feasible one. Trial 0 is the configuration as it is
(the baseline to beat).

The space file (TOML) has one table per configuration key under ``params``::

    [params."planner.lateral_safety_factor"]
    low = 0.5
    high = 0.8
    [params."mapper.slam.gyro_noise_density_radps_rthz"]
    low = 1e-4
    high = 1e-3
    log = true
    [params."controller.steering_law"]
    choices = ["preview", "pure_pursuit"]

``step`` (a grid step) and ``type = "int"`` are also taken.
"""

from __future__ import annotations

import csv
import json
import logging
import math
import statistics
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import tomli_w

from common.config import read_toml
from common.errors import ConfigError
from orchestrator.config import AppConfig
from scale.engine import require_optuna
from scale.runners import runner_session
from scale.runs import RunSpec, configured, nested

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Param:
    """One searched configuration key."""

    key: str
    low: float | None = None
    high: float | None = None
    log: bool = False
    step: float | None = None
    integer: bool = False
    choices: tuple[Any, ...] = ()

    def suggest(self, trial: Any) -> Any:
        if self.choices:
            return trial.suggest_categorical(self.key, list(self.choices))
        assert self.low is not None and self.high is not None
        if self.integer:
            return trial.suggest_int(self.key, int(self.low), int(self.high),
                                     step=int(self.step or 1), log=self.log)
        return trial.suggest_float(self.key, self.low, self.high, step=self.step, log=self.log)


def load_space(path: Path, config: AppConfig) -> list[Param]:
    """The parameters of a space file, each checked against the configuration
    (:class:`ConfigError`, one line naming the file and the key)."""
    data = read_toml(path)
    tables = data.get("params")
    if not isinstance(tables, dict) or not tables:
        raise ConfigError(f"{path}: expected tables [params.\"section.key\"] with low/high or "
                          f"choices")
    params = []
    for key, spec in tables.items():
        if not isinstance(spec, dict):
            raise ConfigError(f"{path}: params.{key} must be a table with low/high or choices")
        unknown = set(spec) - {"low", "high", "log", "step", "type", "choices"}
        if unknown:
            raise ConfigError(f"{path}: params.{key}: unknown field(s) "
                              f"{', '.join(sorted(unknown))}")
        low: Any = spec.get("low")
        high: Any = spec.get("high")
        if "choices" in spec:
            if not isinstance(spec["choices"], list) or not spec["choices"]:
                raise ConfigError(f"{path}: params.{key}.choices must be a non-empty list")
            param = Param(key, choices=tuple(spec["choices"]))
        else:
            if not all(isinstance(v, (int, float)) and math.isfinite(v) for v in (low, high)) \
                    or low >= high:
                raise ConfigError(f"{path}: params.{key} needs numbers low < high, got "
                                  f"{low!r}, {high!r}")
            if spec.get("log") and low <= 0:
                raise ConfigError(f"{path}: params.{key}: log scale needs low > 0")
            param = Param(key, float(low), float(high), bool(spec.get("log", False)),
                          spec.get("step"), spec.get("type") == "int")
        values: list[Any] = [low, high] if not param.choices else list(param.choices)
        for value in values:  # every end of the range must be a valid setting of that key
            configured(config, ((key, int(value) if param.integer else value),), str(path))
        params.append(param)
    return params


def current_value(config: AppConfig, key: str) -> Any:
    """The configuration's value at a dotted key."""
    value: Any = config
    for part in key.split("."):
        value = getattr(value, part)
    return value


@dataclass
class TrialResult:
    number: int
    params: dict[str, Any]
    value: float
    """Mean best lap (s); a run without a lap counts as the sim's time limit."""
    cones_hit: int
    off_track: int
    failed: int
    laps: list[float]

    @property
    def feasible(self) -> bool:
        return self.cones_hit == 0 and self.off_track == 0 and self.failed == 0


def score(number: int, params: dict[str, Any], rows: list[dict[str, Any]],
          limit_s: float) -> TrialResult:
    """A trial's objective and constraint from its runs' rows."""
    laps = [float(r["best_lap_time_s"]) if r["best_lap_time_s"] != "" else limit_s for r in rows]
    failed = sum(1 for r in rows if r["error"] or r["best_lap_time_s"] == ""
                 or str(r["finished"]).lower() != "true")
    return TrialResult(number, params, statistics.fmean(laps) if laps else limit_s,
                       sum(int(r["cones_hit"] or 0) for r in rows),
                       sum(int(r["off_track"] or 0) for r in rows), failed, laps)


TRIAL_COLUMNS = ("trial", "value_s", "feasible", "cones_hit", "off_track", "failed", "laps_s",
                 "params")


def tune(config: AppConfig, params: list[Param], tracks: list[str], seeds: list[int],
         laps: int, trials: int, out_dir: Path, mission: str | None = None,
         address: str | None = None, num_cpus: int | None = None, sampler_seed: int = 0,
         batch: int | None = None, base_config: Path | None = None, engine: str = "auto"
         ) -> dict[str, Any]:
    """Run the study; write ``OUT/trials.csv``, ``OUT/best.toml`` and ``OUT/tune.json``;
    return the ``tune.json`` content."""
    optuna = require_optuna()
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    out_dir.mkdir(parents=True, exist_ok=True)
    sampler = optuna.samplers.TPESampler(seed=sampler_seed)
    study = optuna.create_study(direction="minimize", sampler=sampler)
    study.enqueue_trial({p.key: current_value(config, p.key) for p in params},
                        user_attrs={"baseline": True})
    limit_s = config.run.max_sim_time_s
    results: list[TrialResult] = []
    wall0 = time.perf_counter()
    with runner_session(engine, address, num_cpus) as runner:
        runs_per_trial = len(tracks) * len(seeds)
        size = batch or max(1, math.ceil(runner.info.cpus / runs_per_trial))
        with (out_dir / "trials.csv").open("w", newline="") as fh:
            writer = csv.writer(fh)
            writer.writerow(TRIAL_COLUMNS)
            while len(results) < trials:
                asked = [study.ask() for _ in range(min(size, trials - len(results)))]
                settings = [{p.key: p.suggest(t) for p in params} for t in asked]
                # every run of the batch is queued before the first result is read
                handles = [runner.submit(config, [
                    RunSpec(track, seed, laps, mission, (), tuple(s.items()))
                    for track in tracks for seed in seeds]) for s in settings]
                for trial, setting, trial_runs in zip(asked, settings, handles, strict=True):
                    rows = [runner.row(h, spec) for h, spec in trial_runs.items()]
                    result = score(trial.number, setting, rows, limit_s)
                    trial.set_constraint("cones_hit", result.cones_hit)
                    trial.set_constraint("off_track_or_failed", result.off_track + result.failed)
                    study.tell(trial, result.value)
                    results.append(result)
                    writer.writerow([result.number, round(result.value, 4), result.feasible,
                                     result.cones_hit, result.off_track, result.failed,
                                     ";".join(f"{v:.3f}" for v in result.laps),
                                     json.dumps(setting)])
                    fh.flush()
                    log.info("trial %d: %.3f s, feasible=%s", result.number, result.value,
                             result.feasible)
    baseline = results[0]
    feasible = [r for r in results if r.feasible]
    best = min(feasible, key=lambda r: r.value) if feasible else None
    summary: dict[str, Any] = {
        "tracks": tracks, "seeds": seeds, "laps": laps, "trials": len(results),
        "sampler": f"optuna {optuna.__version__} TPESampler(seed={sampler_seed}), "
                   f"batches of {size}",
        "engine": runner.info.as_dict(), "wall_s": round(time.perf_counter() - wall0, 1),
        "baseline": _as_dict(baseline),
        "best": _as_dict(best) if best else None,
        "improvement_s": round(baseline.value - best.value, 4) if best else None,
    }
    if best is not None:
        write_override(out_dir / "best.toml", best.params, base_config)
        summary["best_toml"] = str(out_dir / "best.toml")
    (out_dir / "tune.json").write_text(json.dumps(summary, indent=2) + "\n")
    return summary


def _as_dict(result: TrialResult) -> dict[str, Any]:
    return {"trial": result.number, "mean_best_lap_s": round(result.value, 4),
            "cones_hit": result.cones_hit, "off_track": result.off_track,
            "failed": result.failed, "feasible": result.feasible, "params": result.params}


def _merge(base: dict[str, Any], top: dict[str, Any]) -> dict[str, Any]:
    out = dict(base)
    for key, value in top.items():
        if isinstance(value, dict) and isinstance(out.get(key), dict):
            out[key] = _merge(out[key], value)
        else:
            out[key] = value
    return out


def write_override(path: Path, params: dict[str, Any], base_config: Path | None = None) -> None:
    """The best setting as a TOML override for ``--config`` (on top of the tuned ``--config``
    file, when there was one)."""
    data = nested(params)
    if base_config is not None:
        data = _merge(read_toml(base_config), data)
    header = "# written by 'python main.py tune': the best feasible setting found\n"
    path.write_text(header + tomli_w.dumps(data))
