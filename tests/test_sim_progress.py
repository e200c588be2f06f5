"""Long runs say how far they are: a plain progress line when not on a terminal."""

from __future__ import annotations

import logging

import pytest

from orchestrator import sim


def test_plain_progress_lines_when_not_on_a_terminal(monkeypatch: pytest.MonkeyPatch,
                                                     caplog: pytest.LogCaptureFixture) -> None:
    """No bar (not a terminal): one line per PROGRESS_LINE_S of wall time, with the simulated
    time, the phase, laps done of N and the last lap time; none before that."""
    clock = iter([0.0, 1.0, sim.PROGRESS_LINE_S + 0.5, sim.PROGRESS_LINE_S + 1.0,
                  2 * sim.PROGRESS_LINE_S + 1.0])
    monkeypatch.setattr(sim.time, "perf_counter", lambda: next(clock))
    caplog.set_level(logging.INFO, logger="progress")
    progress = sim._Progress(bar=False, laps=10)
    progress.update(10.0, 0, "exploration")
    assert not caplog.records
    progress.update(40.0, 1, "autonomous", 25.3)
    progress.update(41.0, 1, "autonomous", 25.3)  # within the period: no line
    progress.update(70.0, 2, "autonomous", 24.9)
    lines = [r.getMessage() for r in caplog.records]
    assert len(lines) == 2
    assert "t=40 s" in lines[0] and "laps 1 of 10" in lines[0] and "last lap 25.30 s" in lines[0]
    assert "laps 2 of 10" in lines[1]
