"""Planner on hard layouts: the chosen path stays inside the track and clear of every cone."""

from __future__ import annotations

import math

import numpy as np
import pytest

from common.messages import ConeColour, ConeMap, MapState, PoseEstimate
from orchestrator.config import AppConfig
from planner.path_planner import PathPlanner

WIDTH_M = 3.5
CONE_RADIUS_M = 0.114


def resample(poly: np.ndarray, step: float) -> np.ndarray:
    seg = np.linalg.norm(np.diff(poly, axis=0), axis=1)
    s = np.r_[0.0, np.cumsum(seg)]
    t = np.arange(0.0, s[-1], step)
    return np.stack([np.interp(t, s, poly[:, 0]), np.interp(t, s, poly[:, 1])], axis=1)


def normals(poly: np.ndarray) -> np.ndarray:
    tan = np.gradient(poly, axis=0)
    tan /= np.linalg.norm(tan, axis=1, keepdims=True)
    return np.stack([-tan[:, 1], tan[:, 0]], axis=1)


def cones_along(centre: np.ndarray, width: float = WIDTH_M, spacing: float = 3.0
                ) -> tuple[np.ndarray, np.ndarray]:
    c = resample(centre, spacing)
    n = normals(c)
    left, right = c + n * width / 2, c - n * width / 2
    colours = np.r_[np.full(len(left), ConeColour.BLUE), np.full(len(right), ConeColour.YELLOW)]
    return np.vstack([left, right]), colours


def chicane() -> np.ndarray:
    x = np.arange(-10.0, 70.0, 0.25)
    y = 2.5 * (np.tanh((x - 20.0) / 4.0) - np.tanh((x - 40.0) / 4.0)) / 2.0
    return np.stack([x, y], axis=1)


def hairpin(r: float = 6.0) -> np.ndarray:
    straight = np.stack([np.arange(-10.0, 20.0, 0.25), np.zeros(120)], axis=1)
    a = np.linspace(-np.pi / 2, np.pi / 2, 120)
    turn = np.stack([20.0 + r * np.cos(a), r + r * np.sin(a)], axis=1)
    back = np.stack([np.arange(20.0, -10.0, -0.25), np.full(120, 2 * r)], axis=1)
    return np.vstack([straight, turn[1:], back[1:]])


def skidpad(r: float = 9.125) -> np.ndarray:
    """Figure of eight through the origin heading +x: right circle (clockwise) then left."""
    a = np.linspace(0.0, 2 * np.pi, 240, endpoint=False)
    right = np.stack([r * np.sin(a), -r + r * np.cos(a)], axis=1)  # centre (0, -r), clockwise
    left = np.stack([r * np.sin(a), r - r * np.cos(a)], axis=1)  # centre (0, r), CCW
    return np.vstack([right, left])


def make_map(cones: np.ndarray, colours: np.ndarray, x: float, y: float, yaw: float,
             v: float = 8.0) -> MapState:
    n = len(cones)
    cmap = ConeMap(cones, np.tile(np.eye(2) * 0.01, (n, 1, 1)), colours.astype(np.int64),
                   np.ones(n, np.int64), np.ones(n), np.arange(n))
    pose = PoseEstimate(0.0, x, y, yaw, v, 0.0, 0.0, np.eye(3) * 1e-4)
    return MapState(0.0, pose, cmap)


def heading_at(centre: np.ndarray, i: int) -> float:
    d = centre[min(i + 1, len(centre) - 1)] - centre[max(i - 1, 0)]
    return math.atan2(d[1], d[0])


def assert_inside(plan_xy: np.ndarray, centre: np.ndarray, all_cones: np.ndarray,
                  config: AppConfig) -> None:
    half_car = config.car.width_m / 2
    # every path point clear of every cone (seen or not) by half the car plus a cone
    d_cone = np.min(np.linalg.norm(plan_xy[:, None, :] - all_cones[None, :, :], axis=2), axis=1)
    assert d_cone.min() > half_car + CONE_RADIUS_M, f"path {d_cone.min():.2f} m from a cone"
    # and inside the lane: the car's side stays within the track edges
    d_centre = np.min(np.linalg.norm(plan_xy[:, None, :] - centre[None, :, :], axis=2), axis=1)
    assert d_centre.max() < WIDTH_M / 2 - half_car + 0.05, f"path {d_centre.max():.2f} m off"


def drive_along(centre: np.ndarray, cones: np.ndarray, colours: np.ndarray,
                record: bool, closed_loop: bool = False, offset: float = 0.3,
                yaw_error: float = 0.1, visible: np.ndarray | None = None) -> None:
    config = AppConfig()
    planner = PathPlanner(config.planner, config.car)
    seen = cones if visible is None else cones[visible]
    seen_colours = colours if visible is None else colours[visible]
    if record:
        for p in centre[::6]:
            planner.book.record(float(p[0]), float(p[1]))
    x0, y0 = centre[0]
    planner.start_autonomous(make_map(seen, seen_colours, float(x0), float(y0),
                                      heading_at(centre, 0)))
    assert planner.frame is not None
    n = normals(centre)
    checked = 0
    for i in range(8, len(centre) - 60, 12):
        sign = 1.0 if (i // 12) % 2 else -1.0
        p = centre[i] + n[i] * offset * sign
        yaw = heading_at(centre, i) + yaw_error * sign
        plan = planner.plan(make_map(seen, seen_colours, float(p[0]), float(p[1]), yaw), 0.0)
        assert plan.chosen_index >= 0, f"no feasible manoeuvre at {p}"
        chosen = plan.candidates[plan.chosen_index]
        # the horizon part (the rest is held along the frame for the look-ahead)
        assert_inside(chosen[:30], centre, cones, config)
        assert plan.manoeuvre.speed_mps.min() >= 0.0
        assert np.all(np.diff(plan.manoeuvre.t_s) > 0.0)
        checked += 1
    assert checked >= 5


def test_chicane_from_cones_only() -> None:
    centre = chicane()
    cones, colours = cones_along(centre)
    drive_along(centre, cones, colours, record=False)


def test_chicane_from_recorded_waypoints() -> None:
    centre = chicane()
    cones, colours = cones_along(centre)
    drive_along(centre, cones, colours, record=True)


def test_hairpin() -> None:
    centre = hairpin()
    cones, colours = cones_along(centre, spacing=2.0)
    drive_along(centre, cones, colours, record=False, offset=0.2, yaw_error=0.05)


def test_only_one_side_of_cones_visible() -> None:
    centre = chicane()
    cones, colours = cones_along(centre)
    blue_only = colours == ConeColour.BLUE
    drive_along(centre, cones, colours, record=False, visible=blue_only, offset=0.2)


def test_skidpad_crossing_follows_the_branch_being_driven() -> None:
    centre = skidpad()
    n_half = len(centre) // 2
    r = 9.125
    a = np.linspace(0, 2 * np.pi, 24, endpoint=False)
    cones, colours = [], []
    for cy, inner_colour, outer_colour in ((-r, ConeColour.YELLOW, ConeColour.BLUE),
                                           (r, ConeColour.BLUE, ConeColour.YELLOW)):
        inner = np.stack([(r - 1.5) * np.cos(a), cy + (r - 1.5) * np.sin(a)], axis=1)
        outer = np.stack([(r + 1.5) * np.cos(a), cy + (r + 1.5) * np.sin(a)], axis=1)
        other = np.array([0.0, -cy])
        outer = outer[np.linalg.norm(outer - other, axis=1) > r + 2.5]  # gap at the crossing
        cones += [inner, outer]
        colours += [np.full(len(inner), inner_colour), np.full(len(outer), outer_colour)]
    cone_xy, cone_col = np.vstack(cones), np.concatenate(colours)
    config = AppConfig()
    planner = PathPlanner(config.planner, config.car)
    # the whole figure of eight is one lap (the first return to the start is half of it)
    planner.book.set_points(centre[::4], closed=True)
    planner.start_autonomous(make_map(cone_xy, cone_col, 0.0, 0.0, 0.0))
    frame = planner.frame
    assert frame is not None and frame.closed
    # drive the whole figure of eight in steps; at the crossing the projection must stay on the
    # branch being driven (the progress only grows)
    progress = []
    for i in range(2, 2 * n_half, 8):
        p = centre[i]
        yaw = heading_at(centre, i)
        plan = planner.plan(make_map(cone_xy, cone_col, float(p[0]), float(p[1]), yaw), 0.0)
        assert plan.chosen_index >= 0
        chosen = plan.candidates[plan.chosen_index][:20]
        d_cone = np.min(np.linalg.norm(chosen[:, None] - cone_xy[None], axis=2))
        assert d_cone > config.car.width_m / 2 + CONE_RADIUS_M
        progress.append(planner.laps.progress_m)
    assert np.all(np.diff(progress) > 0.0)
    assert progress[-1] == pytest.approx(frame.length_m, rel=0.1)
