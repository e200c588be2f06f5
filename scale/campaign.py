"""A campaign: every (track, seed, fault, setting) run as one Ray task, rows streamed to a file.

``OUT/results.csv`` gets one row per run as it finishes (:data:`scale.runs.COLUMNS`; a failed
run is a row with its ``error`` filled); ``OUT/runs/<run_id>.json`` keeps each run's full
summary; ``OUT/campaign.json`` says what was asked and what ran it; ``OUT/report.html`` is
written at the end (:mod:`scale.report`). A campaign started again on the same folder skips the
runs whose rows are already in ``results.csv`` (an interrupted campaign resumes).
"""

from __future__ import annotations

import csv
import datetime as dt
import json
import logging
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from common.errors import FsdError
from orchestrator.config import AppConfig
from scale.engine import EngineInfo
from scale.runners import runner_session
from scale.runs import COLUMNS, RunRequest, RunSpec

log = logging.getLogger(__name__)
progress_log = logging.getLogger("progress")

RESULTS = "results.csv"
CAMPAIGN = "campaign.json"
REPORT = "report.html"


class CampaignError(FsdError):
    """A campaign folder that cannot be resumed or written."""


def read_rows(path: Path) -> list[dict[str, str]]:
    """The rows of a ``results.csv`` ([] when there is none); :class:`CampaignError` when its
    header is not this version's."""
    if not path.exists():
        return []
    with path.open(newline="") as fh:
        reader = csv.DictReader(fh)
        if reader.fieldnames is None:
            return []
        if tuple(reader.fieldnames) != COLUMNS:
            raise CampaignError(f"{path}: not a results file of this version (columns "
                                f"{','.join(reader.fieldnames)[:80]}...); use another --out")
        # a line cut short by an interrupted write lacks fields: that run is run again
        return [row for row in reader
                if row.get("run_id") and all(row.get(c) is not None for c in COLUMNS)]


@dataclass
class CampaignResult:
    """What a campaign produced: every row of ``results.csv`` and how this part of it went."""

    rows: list[dict[str, Any]]
    ran: int
    failed: int
    skipped: int
    wall_s: float
    engine: EngineInfo


class _Sink:
    """Appends rows to ``results.csv`` (header first when new), flushed row by row."""

    def __init__(self, path: Path) -> None:
        new = not path.exists() or path.stat().st_size == 0
        cut = not new and path.read_bytes()[-1:] != b"\n"  # an interrupted write's last line
        self._fh = path.open("a", newline="")
        if cut:
            self._fh.write("\n")
        self._writer = csv.DictWriter(self._fh, fieldnames=COLUMNS, extrasaction="ignore")
        if new:
            self._writer.writeheader()
            self._fh.flush()

    def write(self, row: dict[str, Any]) -> None:
        self._writer.writerow(row)
        self._fh.flush()

    def close(self) -> None:
        self._fh.close()


def _write_json(path: Path, data: dict[str, Any]) -> None:
    path.write_text(json.dumps(data, indent=2, default=str) + "\n")


def run_campaign(config: AppConfig, request: RunRequest, out_dir: Path,
                 address: str | None = None, num_cpus: int | None = None,
                 progress: bool = True, argv: list[str] | None = None,
                 engine: str = "auto") -> CampaignResult:
    """Run every combination of ``request`` not yet in ``out_dir/results.csv`` on ``engine``
    (:mod:`scale.runners`: ``auto`` is a process pool here, Ray with an ``address``)."""
    from tqdm import tqdm

    out_dir.mkdir(parents=True, exist_ok=True)
    (out_dir / "runs").mkdir(exist_ok=True)
    results = out_dir / RESULTS
    previous = read_rows(results)
    done_ids = {row["run_id"] for row in previous}
    specs = request.specs()
    todo = [spec for spec in specs if spec.run_id not in done_ids]
    skipped = len(specs) - len(todo)
    wanted = {spec.run_id for spec in specs}
    meta: dict[str, Any] = {
        "request": {"tracks": request.tracks, "seeds": request.seeds, "laps": request.laps,
                    "mission": request.mission,
                    "faults": [list(f) for f in request.faults],
                    "settings": [dict(s) for s in request.settings], "argv": argv},
        "runs": len(specs), "resumed_rows": skipped,
        "started": dt.datetime.now(dt.UTC).isoformat(timespec="seconds"),
    }
    wall0 = time.perf_counter()
    rows: list[dict[str, Any]] = [r for r in previous if r["run_id"] in wanted]
    failed = 0
    with runner_session(engine, address, num_cpus) as runner:
        meta["engine"] = runner.info.as_dict()
        _write_json(out_dir / CAMPAIGN, meta)
        pending: dict[Any, RunSpec] = runner.submit(config, todo)
        sink = _Sink(results)
        bar = tqdm(total=len(specs), initial=skipped, desc="campaign", unit="run",
                   disable=not progress, file=sys.stderr, dynamic_ncols=True)
        try:
            while pending:
                for handle in runner.finished(list(pending)):
                    spec = pending.pop(handle)
                    row = runner.row(handle, spec)
                    summary = row.pop("summary", None)
                    if summary is not None:
                        _write_json(out_dir / "runs" / f"{spec.run_id}.json",
                                    {"spec": spec.to_json(), "summary": summary})
                    sink.write(row)
                    rows.append(row)
                    if row["error"]:
                        failed += 1
                        log.warning("run %s seed %s failed: %s", spec.track, spec.seed,
                                    row["error"])
                    bar.update(1)
                    bar.set_postfix_str(f"done={len(rows)} failed={failed}", refresh=False)
                    if not progress:  # no bar (not a terminal): a plain line per run
                        ran = len(todo) - len(pending)
                        left_s = (time.perf_counter() - wall0) / ran * len(pending)
                        progress_log.info("campaign: %d of %d done, %d failed, about %.0f s left",
                                          len(rows), len(specs), failed, left_s)
        finally:
            bar.close()
            sink.close()
            runner.cancel(list(pending))
    wall_s = time.perf_counter() - wall0
    meta.update(finished=dt.datetime.now(dt.UTC).isoformat(timespec="seconds"),
                wall_s=round(wall_s, 3), ran=len(todo), failed=failed)
    _write_json(out_dir / CAMPAIGN, meta)
    from scale.report import write_report

    write_report(out_dir / REPORT, rows, meta)
    return CampaignResult(rows, len(todo), failed, skipped, wall_s, runner.info)
