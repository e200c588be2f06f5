"""The Foxglove scene shows the estimate's uncertainty, the candidate manoeuvres and the driven
trace (in small segments)."""

from __future__ import annotations

import numpy as np
import pytest

from bench.bench_render import synthetic_scene
from recordings import foxglove_views as fv


def test_pose_ellipse_is_two_sigma() -> None:
    cov = np.array([[4.0, 0.0], [0.0, 1.0]])
    pts = fv.pose_ellipse_xy_m(1.0, 2.0, cov, steps=32) - [1.0, 2.0]
    # x^2/16 + y^2/4 = 1 (2 sigma of standard deviations 2 and 1), whichever axis eigh orders
    # first.
    assert pts[:, 0] ** 2 / 16 + pts[:, 1] ** 2 / 4 == pytest.approx(np.ones(32))
    assert np.all(np.isfinite(fv.pose_ellipse_xy_m(0.0, 0.0, np.full((2, 2), np.nan))))


def test_scene_has_ellipse_candidates_and_chosen() -> None:
    map_state, plan, _ = synthetic_scene(1.0)
    car = next(e for e in fv.map_scene(map_state).entities if e.id == "car")
    assert len(car.lines) == 1 and car.lines[0].type == car.lines[0].LINE_LOOP
    lines = fv.plan_scene(plan).entities[0].lines
    # baseframe + 8 candidates not chosen + the chosen manoeuvre
    assert len(lines) == 1 + (len(plan.candidates) - 1) + 1


def test_trace_segments_cover_the_path_once_each() -> None:
    trace = fv.TraceSegments(period_s=1.0)
    updates = []
    for k in range(35):  # 3.4 s at 10 Hz along x
        update = trace.add(0.1 * k, 0.5 * k, 0.0)
        if update is not None:
            updates.append(update)
    assert len(updates) == 3
    ids = [u.entities[0].id for u in updates]
    assert ids == ["trace/000000", "trace/000001", "trace/000002"]
    xs = [[p.x for p in u.entities[0].lines[0].points] for u in updates]
    assert xs[0][0] == 0.0 and xs[1][0] == xs[0][-1] and xs[2][0] == xs[1][-1]  # joined
    assert xs[2][-1] == pytest.approx(15.0)
