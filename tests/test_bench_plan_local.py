"""``bench plan_local``'s core on a few cone views of the built-in track: the views grow as the
car drives, and both colour modes report every figure (timings are not checked here)."""

from __future__ import annotations

import argparse

import numpy as np

from bench.bench_plan_local import add_arguments, cone_views, measure, path_inside, run
from orchestrator.config import AppConfig
from simulator.tracks import load_track

FIELDS = {"colour", "views", "exploring", "closed_at_m", "paths", "inside", "inside_fraction",
          "path_median_ms", "path_p99_ms", "local_median_ms", "local_p99_ms",
          "plan_median_ms", "plan_p99_ms", "local_over_plan"}


def test_views_grow_along_the_lap() -> None:
    track = load_track("default")
    views = cone_views(track, step_m=3.0, limit=6)
    assert len(views) == 6
    counts = [int(v.seen.sum()) for v in views]
    assert counts[0] > 0 and counts == sorted(counts) and counts[-1] < len(track.cones_xy_m)
    assert np.all(views[-1].seen[views[0].seen])  # a mapped cone stays mapped
    assert path_inside(track, track.centreline_xy_m[:20])
    assert not path_inside(track, track.centreline_xy_m[:3] + 10.0)


def test_both_colour_modes_report_every_figure() -> None:
    config = AppConfig()
    track = load_track("default")
    views = cone_views(track, step_m=3.0, limit=5)
    for colour in (True, False):
        figures = measure(config, track, views, colour=colour)
        summary = figures.summary()
        assert set(summary) == FIELDS
        assert summary["views"] == 5 and summary["exploring"] == 5
        assert 0 < summary["paths"] <= 5 and 0 <= summary["inside"] <= summary["paths"]
        assert 0.0 <= summary["inside_fraction"] <= 1.0
        assert len(figures.local_ms) == len(figures.plan_ms) == 5
        assert summary["local_median_ms"] > 0.0 and summary["local_over_plan"] > 0.0


def test_the_command_prints_its_figure_last(capsys) -> None:
    parser = argparse.ArgumentParser()
    add_arguments(parser)
    args = parser.parse_args(["--track", "default", "--views", "4", "--step-m", "3"])
    assert run(args, AppConfig()) == 0
    lines = capsys.readouterr().out.strip().splitlines()
    assert lines[-1].startswith("plan_local_median_ms=")
    assert "no colour" in "\n".join(lines)
