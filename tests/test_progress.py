"""Progress of long work (:mod:`orchestrator.progress`): plain lines every few seconds when not
on a terminal, a bar with the status on one, and a status function called only when shown."""

from __future__ import annotations

import io
import logging

import pytest

from orchestrator import progress as progress_mod
from orchestrator.progress import Progress, realtime_status


def _clock(monkeypatch: pytest.MonkeyPatch, times: list[float]) -> None:
    it = iter(times)
    monkeypatch.setattr(progress_mod.time, "perf_counter", lambda: next(it))


def test_plain_lines_every_period(monkeypatch: pytest.MonkeyPatch,
                                  caplog: pytest.LogCaptureFixture) -> None:
    _clock(monkeypatch, [0.0, 1.0, 5.5, 6.0, 11.0])
    caplog.set_level(logging.INFO, logger="progress")
    calls: list[int] = []

    def status() -> str:
        calls.append(1)
        return "t=30 s, 3.0x real time"

    bar = Progress("replay", 120, "s of recording", bar=False, period_s=5.0)
    bar.update(10, status)  # 1 s: not yet
    bar.update(30, status)  # 5.5 s: a line
    bar.update(33, status)  # 6 s: within the period
    bar.update(60, "plain")  # 11 s: a line
    lines = [r.getMessage() for r in caplog.records]
    assert lines == ["replay: s of recording 30 of 120, t=30 s, 3.0x real time",
                     "replay: s of recording 60 of 120, plain"]
    assert len(calls) == 1  # the status was made only for the line shown


def test_bar_on_a_terminal_shows_done_of_total_and_status(
        monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture) -> None:
    stream = io.StringIO()
    monkeypatch.setattr(progress_mod.sys, "stderr", stream)
    caplog.set_level(logging.INFO, logger="progress")
    bar = Progress("sim", 10, "laps", bar=True)
    bar.update(3, "t=120 s, 2.0x real time, last lap 25.30 s")
    bar.close()
    text = stream.getvalue()
    assert "3/10" in text and "last lap 25.30 s" in text
    assert not caplog.records  # a bar, no plain lines


def test_realtime_status() -> None:
    assert realtime_status(120.0, 60.0) == "t=120 s, 2.0x real time"
