"""How far ``decode nmea`` agrees with gpsd on a capture: gpsd's fixes grouped by receiver cycle,
and which of them we report once, with nothing else (issue 44).

gpsd's answer for a capture is its JSON report stream, as gpsd's own regression files
(``.chk``) hold it or as ``gpsfake -1 -p`` prints it. Its ``TPV`` reports with a 2D or 3D fix
and a position are its fixes. gpsd may report one cycle several times (after GGA, after RMC,
...) with the positions of different sentences; grouped by their time they are its cycles. A
cycle counts as found when we report one fix with its time (to 1 ms) and one of its positions
(to :data:`TOLERANCE_DEG`); a fix of ours that matches no cycle, or a second fix for a cycle,
is extra. A report gpsd made before it knew the date has no time: it is a cycle keyed by its
position, and when that position is one we report with a time, it was that cycle's early report,
not a cycle of its own.
"""

from __future__ import annotations

import json
import shutil
import subprocess
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

TOLERANCE_DEG = 1e-6
"""Position agreement (deg, about 0.1 m): gpsd prints 9 decimals, the sentences carry 4-8."""

GPSFAKE_TIMEOUT_S = 3600.0
"""Longest a gpsfake run may take (a 100 000-line capture takes about a minute)."""


class GpsfakeError(RuntimeError):
    """gpsfake is not installed, or it failed on a capture."""


def gpsd_fixes(report_text: str) -> list[dict[str, Any]]:
    """Every fix in gpsd's report stream, in order: its JSON ``TPV`` objects with mode >= 2 and
    a position. Echoed sentences and lines that are not JSON are skipped."""
    fixes = []
    for line in report_text.splitlines():
        if not line.startswith("{"):
            continue
        try:
            obj = json.loads(line)
        except json.JSONDecodeError:
            continue
        if obj.get("class") == "TPV" and obj.get("mode", 0) >= 2 and "lat" in obj:
            fixes.append(obj)
    return fixes


def _time_of_day_s(iso: str) -> float:
    hh, mm, ss = iso[11:].rstrip("Z").split(":")
    return int(hh) * 3600 + int(mm) * 60 + float(ss)


def gpsd_cycles(report_text: str) -> dict[object, list[tuple[float, float]]]:
    """gpsd's fixes by cycle: time of day (s, rounded to 1 ms) -> the positions (deg) it
    reported for it; a report without a time is a cycle keyed by its own position."""
    cycles: dict[object, list[tuple[float, float]]] = {}
    for obj in gpsd_fixes(report_text):
        key: object = (round(_time_of_day_s(obj["time"]), 3) if "time" in obj
                       else ("untimed", round(obj["lat"], 6), round(obj["lon"], 6)))
        cycles.setdefault(key, []).append((obj["lat"], obj["lon"]))
    return cycles


def _at(fix: dict[str, Any], positions: list[tuple[float, float]]) -> bool:
    return fix["lat"] is not None and any(
        abs(fix["lat"] - lat) <= TOLERANCE_DEG and abs(fix["lon"] - lon) <= TOLERANCE_DEG
        for lat, lon in positions)


@dataclass(slots=True)
class Agreement:
    """One capture: ``cycles`` gpsd reported, ``found`` of them we report, our ``extra``
    fixes (as ``decode nmea`` prints them)."""

    cycles: int
    found: int
    extra: list[dict[str, Any]] = field(default_factory=list)


def agreement(report_text: str, fixes: list[dict[str, Any]]) -> Agreement:
    """Compare our ``fixes`` (``decode nmea``'s fix objects, without its summary line) with
    gpsd's report stream for the same capture."""
    cycles = gpsd_cycles(report_text)
    matched: set[object] = set()
    extra: list[dict[str, Any]] = []
    for fix in fixes:
        key = None
        if fix["utc_time_s"] is not None:
            timed = round(fix["utc_time_s"], 3)
            if timed in cycles and _at(fix, cycles[timed]):
                key = timed
        if key is None:
            untimed = [k for k in cycles if isinstance(k, tuple) and _at(fix, cycles[k])]
            key = next((k for k in untimed if k not in matched), untimed[0] if untimed else None)
        if key is None or (key in matched and not isinstance(key, tuple)):
            extra.append(fix)
        else:
            matched.add(key)
    early = [k for k in cycles if isinstance(k, tuple) and k not in matched
             and any(_at(fix, cycles[k]) for fix in fixes)]
    return Agreement(len(cycles) - len(early), len(matched), extra)


def gpsfake_reports(capture: Path, gpsfake: str = "gpsfake") -> str:
    """gpsd's report stream for ``capture``: the capture played once through ``gpsfake -1 -p``
    (gpsd on a pseudo-terminal at 38400 baud, its reports on stdout), as gpsd's regression
    files are made. Raises :class:`GpsfakeError` when gpsfake is missing or fails."""
    exe = shutil.which(gpsfake)
    if exe is None:
        raise GpsfakeError(f"{gpsfake!r} not found: install gpsd's tools (Debian: "
                           "apt install gpsd gpsd-clients), or put the capture's gpsd answer "
                           "beside it as CAPTURE.chk")
    # gpsfake plays a copy: it may write beside the file it plays
    with tempfile.TemporaryDirectory(prefix="gpsfake-") as tmp:
        copy = Path(tmp) / capture.name
        copy.write_bytes(capture.read_bytes())
        try:
            done = subprocess.run([exe, "-1", "-p", "-s", "38400", str(copy)],
                                  capture_output=True, timeout=GPSFAKE_TIMEOUT_S, check=False)
        except subprocess.TimeoutExpired as exc:
            raise GpsfakeError(f"gpsfake took over {GPSFAKE_TIMEOUT_S:.0f} s on "
                               f"{capture}") from exc
    text = done.stdout.decode("utf-8", errors="replace")
    if done.returncode != 0 or '"class":"VERSION"' not in text:
        last = done.stderr.decode("utf-8", errors="replace").strip().splitlines()[-1:]
        raise GpsfakeError(f"gpsfake failed on {capture} (exit {done.returncode})"
                           + (f": {last[0]}" if last else ""))
    return text
