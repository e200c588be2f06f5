"""Waypoint book (seed 002, 3.2.1) and waypoints from the cone map (Delaunay midpoints)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from planner.waypoints import WaypointBook, cone_midpoints, waypoints_from_cones
from simulator.tracks import load_track


def test_book_records_every_spacing_and_rejects_nan() -> None:
    book = WaypointBook(spacing_m=1.5)
    for x in np.arange(0.0, 10.0, 0.1):
        book.record(float(x), 0.0)
    assert not book.record(math.nan, 0.0)
    assert book.rejected == 1
    gaps = np.diff(book.points_xy_m[:, 0])
    assert len(book) == 7 and np.all(gaps >= 1.5 - 1e-9) and np.all(gaps < 1.7)


def test_book_drops_reached_waypoints_and_serves_the_next_three() -> None:
    book = WaypointBook(spacing_m=1.0, reach_m=2.5, served=3)
    book.set_points(np.stack([np.arange(0.0, 20.0, 2.0), np.zeros(10)], axis=1), closed=False)
    served = book.next_waypoints(0.0, 0.0)
    np.testing.assert_allclose(served[:, 0], [4.0, 6.0, 8.0])  # 0 and 2 are within 2.5 m
    served = book.next_waypoints(9.0, 0.0)
    np.testing.assert_allclose(served[:, 0], [12.0, 14.0, 16.0])
    np.testing.assert_allclose(book.next_waypoints(30.0, 0.0), [[18.0, 0.0]])  # the end


def test_closed_book_wraps() -> None:
    a = np.linspace(0, 2 * np.pi, 40, endpoint=False)
    book = WaypointBook(reach_m=2.5)
    book.set_points(np.stack([10 * np.cos(a), 10 * np.sin(a)], axis=1), closed=True)
    book.cursor = 38
    served = book.next_waypoints(10 * math.cos(a[39]), 10 * math.sin(a[39]))
    assert len(served) == 3 and book.cursor < 5


def test_close_loop_cuts_one_lap_of_a_longer_drive() -> None:
    a = np.linspace(0, 2 * np.pi * 1.3, 400)
    book = WaypointBook(spacing_m=1.0)
    for x, y in zip(20 * np.sin(a), 20 - 20 * np.cos(a), strict=True):
        book.record(float(x), float(y))
    assert book.close_loop()
    pts = book.points_xy_m
    length = np.sum(np.linalg.norm(np.diff(pts, axis=0), axis=1))
    assert abs(length - 2 * np.pi * 20) < 3.0


@pytest.mark.parametrize(("short_of_start_m", "bridged"), [(8.0, True), (20.0, False)])
def test_close_loop_bridges_a_drive_that_stopped_short_of_its_start(
        short_of_start_m: float, bridged: bool) -> None:
    """The map's loop closed before the car reached the start: a drive ending 8 m short of it,
    heading for it, is a lap (the periodic baseframe bridges the gap); 20 m short is not."""
    radius = 20.0
    a = np.linspace(0.0, 2 * np.pi - short_of_start_m / radius, 300)
    book = WaypointBook(spacing_m=1.0)
    for x, y in zip(radius * np.sin(a), radius - radius * np.cos(a), strict=True):
        book.record(float(x), float(y))
    assert book.close_loop(bridge_max_m=12.0) is bridged
    assert book.closed is bridged


def test_close_loop_does_not_bridge_to_a_start_beside_the_end() -> None:
    """A drive whose end passes 6 m beside its start on a neighbouring straight, heading the
    other way (a hairpin's two straights), is not a lap."""
    out = [(x, 0.0) for x in np.arange(0.0, 60.0, 1.0)]
    turn = [(60.0 + 3.0 * math.sin(t), 3.0 - 3.0 * math.cos(t))
            for t in np.linspace(0.0, math.pi, 10)[1:]]
    back = [(x, 6.0) for x in np.arange(59.0, 2.0, -1.0)]
    book = WaypointBook(spacing_m=1.0)
    for x, y in out + turn + back:
        book.record(float(x), float(y))
    assert not book.close_loop(bridge_max_m=12.0)


def test_waypoints_from_cones_follow_the_centreline_of_a_track() -> None:
    track = load_track("default")
    pts, closed = waypoints_from_cones(track.cones_xy_m, track.colours, (0.0, 0.0), 0.0)
    assert closed
    d = np.min(np.linalg.norm(pts[:, None] - track.centreline_xy_m[None], axis=2), axis=1)
    assert d.max() < 0.5
    travelled = np.sum(np.linalg.norm(np.diff(pts, axis=0), axis=1))
    assert abs(travelled - track.lap_length_m) < 0.1 * track.lap_length_m
    # in the order of travel: the first points lie ahead of the car (+x)
    assert pts[0, 0] > 0.0 and pts[3, 0] > pts[0, 0]


def test_midpoints_need_both_colours() -> None:
    xy = np.array([[0.0, 2.0], [3.0, 2.0], [6.0, 2.0]])
    assert len(cone_midpoints(xy, np.array([1, 1, 1]))) == 0
