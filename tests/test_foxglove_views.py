"""The Foxglove scene shows the estimate's uncertainty, the candidate manoeuvres and the driven
trace (in small segments)."""

from __future__ import annotations

import dataclasses

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


def test_the_cone_drawer_reuses_cones_that_stay_within_half_a_millimetre() -> None:
    map_state, _, _ = synthetic_scene(1.0)
    cones = map_state.cones
    drawer = fv.ConeDrawer()

    def drawn(state) -> list:  # type: ignore[no-untyped-def]
        scene = fv.map_scene(state, drawer=drawer)
        return list(next(e for e in scene.entities if e.id == "cones").cylinders)

    exact = list(next(e for e in fv.map_scene(map_state).entities if e.id == "cones").cylinders)
    first = drawn(map_state)
    assert len(first) == len(exact) == len(cones) > 10
    for a, b in zip(first, exact, strict=True):
        # the same cone: colour, size and height exact, position to the millimetre
        assert (a.color, a.size, a.pose.position.z) == (b.color, b.size, b.pose.position.z)
        assert abs(a.pose.position.x - b.pose.position.x) <= 0.5e-3 + 1e-12
        assert abs(a.pose.position.y - b.pose.position.y) <= 0.5e-3 + 1e-12
    made = len(drawer._made)
    assert made == len(cones)
    # the next map state: every cone moved by 0.1 mm but one, moved by 5 cm
    xy = cones.xy_m.copy()
    x_mm = np.rint(xy[:, 0] * 1000.0) / 1000.0
    xy[:, 0] = x_mm + 0.1e-3  # still rounds to the same millimetre
    xy[0, 0] += 0.05
    moved = dataclasses.replace(map_state, cones=dataclasses.replace(cones, xy_m=xy))
    second = drawn(moved)
    assert len(drawer._made) == made + 1  # one new primitive, the rest reused
    assert second[0].pose.position.x == pytest.approx(x_mm[0] + 0.05, abs=1e-9)
    assert second[1:] == first[1:]
    small = fv.ConeDrawer(limit=3)
    small(xy, cones.colour.tolist(), cones.size.tolist())
    small(xy, cones.colour.tolist(), cones.size.tolist())
    assert len(small._made) <= len(cones)  # cleared once over its limit, never grows on


def test_the_baseframe_is_drawn_again_only_when_it_changes() -> None:
    _, plan, _ = synthetic_scene(1.0)
    memo = fv.LineMemo()

    def baseframe_line(p):  # type: ignore[no-untyped-def]
        return fv.plan_scene(p, baseframe_memo=memo).entities[0].lines[0]

    exact = fv.plan_scene(plan).entities[0].lines[0]
    assert baseframe_line(plan) == exact
    drawn = memo._line
    assert baseframe_line(plan) == exact and memo._line is drawn  # reused
    bf = plan.baseframe
    assert bf is not None
    moved = dataclasses.replace(plan, baseframe=dataclasses.replace(bf, x_m=bf.x_m + 1.0))
    line = baseframe_line(moved)
    assert memo._line is not drawn
    assert [p.x for p in line.points] == pytest.approx((bf.x_m + 1.0).tolist())
    assert baseframe_line(plan) == exact  # and back
