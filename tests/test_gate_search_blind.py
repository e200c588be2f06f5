"""Without colours (the camera dead) the gate search tells a lane's two rows of cones apart by
their shape (planner/gate_search.py): an edge along one row is no gate, nor is an edge with a
cone standing in it; and the way the car drove says which cones were on its left and right
(planner/gate_rows.py)."""

from __future__ import annotations

import numpy as np
import pytest

import planner.gate_search as gs
from common.messages import ConeColour
from planner.exploration_path import ENTRY_BEHIND_M, exploration_path
from planner.gate_rows import crossings, rows_driven
from planner.gate_search import cone_in_gate, gate_search_path
from simulator.hard_tracks import first_arc, hard_track

UNKNOWN = int(ConeColour.UNKNOWN)
WIDTH_M = 3.5


def _lane_beside_another(gap_m: float = 6.0) -> tuple[np.ndarray, np.ndarray]:
    """Cones seen within 22 m of a car at the origin heading +x in a 3.4 m lane (its rows
    2.7 m and 2.4 m apart), and another lane (3.8 m wide) running the same way ``gap_m``
    beyond the right row (an infield between two stretches of track, as on FSSIM FSI); and
    the way the car drove up its lane (M, 2)."""
    left = np.c_[np.arange(-20.0, 16.0, 2.7), np.full(14, 1.7)]
    xr = np.arange(-21.6, 16.0, 2.4)
    right = np.c_[xr, np.full(len(xr), -1.7)]
    xo = np.arange(-5, 12) * 2.8
    near = np.c_[xo, np.full(len(xo), -1.7 - gap_m)]
    far = np.c_[xo + 1.4, np.full(len(xo), -1.7 - gap_m - 3.8)]
    cones = np.r_[left, right, near, far]
    driven = np.c_[np.linspace(-30.0, -3.0, 30), np.zeros(30)]
    return cones[np.hypot(*cones.T) < 22.0], driven


def test_an_edge_along_a_row_is_no_gate_without_colours(monkeypatch) -> None:
    """Two cones of the right row joined as a gate turn the path out through its own
    boundary, and a gate across the infield (6 m, no wider than a bend's gate may be) leads
    into the other lane: the cone such a gate adds goes on the other row in line and not its
    own, so it is no gate."""
    cones, driven = _lane_beside_another()
    colours = np.full(len(cones), UNKNOWN)
    path, _ = gate_search_path(cones, colours, np.zeros(2), 0.0, WIDTH_M, 2.5, driven)
    assert len(path) >= 4 and path[-1][0] > 6.0
    assert np.all(np.abs(path[:, 1]) < 1.7), path  # in its own lane, between the rows
    monkeypatch.setattr(gs._Search, "_continues_the_other_row", lambda self, s, g: False)
    blind, _ = gate_search_path(cones, colours, np.zeros(2), 0.0, WIDTH_M, 2.5, driven)
    assert blind[:, 1].min() < -1.7 - 6.0, blind  # without the rule: into the other lane


def test_the_way_driven_gives_the_rows_in_order() -> None:
    """The cones a path drove past, each on its side, in the order passed (a cone's side from
    the edges the way crossed)."""
    from scipy.spatial import Delaunay

    xs = np.arange(0.0, 12.01, 3.0)
    xy = np.r_[np.c_[xs, np.full(len(xs), 1.75)], np.c_[xs + 1.5, np.full(len(xs), -1.75)]]
    tri = Delaunay(xy)
    way = np.c_[np.linspace(-1.0, 9.0, 21), np.zeros(21)]
    left, right = rows_driven(crossings(xy, tri.simplices, way), xy, WIDTH_M)
    assert left == [0, 1, 2, 3]  # x = 0, 3, 6 and 9 (its edge to x = 7.5 crossed at 8.25)
    assert right == [5, 6, 7]  # x = 1.5, 4.5 and 7.5; not 10.5 (its edges cross y = 0 past 9)
    back_left, back_right = rows_driven(crossings(xy, tri.simplices, way[::-1]), xy, WIDTH_M)
    assert set(back_left) == set(right) and set(back_right) == set(left)
    assert back_left == sorted(back_left, reverse=True)  # driven the other way round
    # an edge from the lane's right cone up to a cone 4.5 m beyond its left one (across an
    # infield) is crossed too: that far cone is on the left, but no cone of the lane
    xy = np.array([[0.0, 1.5], [0.0, -1.5], [2.0, 4.5]])
    crossed = crossings(xy, Delaunay(xy).simplices, np.array([[-1.0, 0.0], [1.5, 0.0]]))
    assert set(crossed) == {(0, 1), (1, 2)}
    assert rows_driven(crossed, xy, WIDTH_M) == ([0], [1])
    assert rows_driven(crossed, xy, np.inf) == ([0, 2], [1])


@pytest.fixture(scope="module")
def hairpin() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """hard:hairpins' first hairpin (rules minimum: 9 m outer diameter, 3 m wide): its cones
    (N, 2), the car's poses (x, y, yaw) on the centreline every 1.5 m from 6 m before its arc
    to its start (P, 3) and the bend's centre (2,)."""
    track = hard_track("hairpins")
    first, heading, centre = first_arc(track)
    at = np.arange(first - 12, first + 1, 3)  # samples are 0.5 m apart
    poses = np.column_stack([track.centreline_xy_m[at], heading[at]])
    return np.asarray(track.cones_xy_m), poses, centre


def _goes_round(cones: np.ndarray, pose: np.ndarray, centre: np.ndarray) -> bool:
    """Whether the path through the cones seen within 20 m of ``pose``, without colours,
    comes back past the hairpin's centre (round the bend, not stopped at its entry)."""
    x, y, yaw = pose
    seen = np.hypot(cones[:, 0] - x, cones[:, 1] - y) < 20.0
    path = exploration_path(cones[seen], np.full(int(seen.sum()), UNKNOWN), (x, y), yaw,
                            track_width_m=WIDTH_M, behind_m=ENTRY_BEHIND_M)
    beyond = path[path[:, 1] > centre[1] + 1.0]  # the way out, past the bend's middle
    return len(beyond) > 0 and float(beyond[:, 0].min()) < centre[0] - 1.0


def test_a_hairpins_outer_row_bends_on_to_where_the_inner_chord_points(hairpin,
                                                                        monkeypatch) -> None:
    """Into a rules-minimum hairpin, the inner row's chord, straight on, meets the outer row,
    which turns 30 degrees a cone: the outer cone there goes on its own row bending, and the
    path through the gates goes round the bend from every pose. A row held straight (the same
    tolerance for its own row as for the other's) stopped it at the entry."""
    cones, poses, centre = hairpin
    assert all(_goes_round(cones, pose, centre) for pose in poses)
    monkeypatch.setattr(gs, "OWN_ROW_TOLERANCE", gs.ROW_TOLERANCE)
    assert not all(_goes_round(cones, pose, centre) for pose in poses)


def test_a_cone_in_an_edge_makes_it_no_gate(monkeypatch) -> None:
    """A bend wider than any gate (EUFS Hairpin, 7 m): the car's nearest cones ahead on
    either hand are two cones of the outer row, 5.9 m apart, with the row's cone between
    them standing 1 m beyond their edge's middle. Without colours that edge is no gate, for
    the search and for the march: the path ends at the car, which stops, instead of heading
    for the row. A cone beside the edge's end, or beyond its middle by more than 0.3 of its
    length, leaves it a gate."""
    a, b = np.array([2.1, 1.9]), np.array([3.3, -3.9])
    assert cone_in_gate(a, b, np.array([[3.5, 0.3]]))
    assert cone_in_gate(a, b, np.array([[1.9, -1.0]]))  # on the car's side, as well
    assert not cone_in_gate(a, b, np.array([[2.3, 1.0], [5.6, -0.7], [0.8, -1.3]]))
    cones = np.array([a, [3.5, 0.3], b])
    colours = np.full(3, UNKNOWN)
    path = exploration_path(cones, colours, (0.0, 0.0), 0.0, track_width_m=WIDTH_M)
    assert len(path) == 1
    monkeypatch.setattr(gs, "CONE_IN_GATE_FRACTION", 0.0)
    assert len(exploration_path(cones, colours, (0.0, 0.0), 0.0, track_width_m=WIDTH_M)) > 1


def _wide_hairpin() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A lane along +x that ends in a right-hand hairpin round an island, wider there (about
    7 m) than a gate between cones of unknown colour may be, as on EUFS Hairpin (its cones
    rounded to 0.1 m, shifted): cones (N, 2), the way the car drove up the lane (M, 2), ending
    about 4 m behind the car at (0.3, -0.5) heading 34 degrees right (into the bend)."""
    outer = [(-10.1, 3.2), (-7.1, 3.3), (-4.2, 3.5), (-0.9, 3.3), (2.1, 2.0), (5.2, 0.0),
             (6.5, -1.4), (6.3, -5.5), (5.3, -7.9)]
    inner = [(-9.1, -2.2), (-6.1, -1.4), (-3.1, -1.8), (-1.0, -3.3), (-2.4, -5.3), (-5.1, -5.3),
             (-8.3, -6.0), (-10.8, -6.5)]
    way_back = [(1.8, -9.0), (-1.7, -9.4), (-4.7, -9.8), (-8.0, -10.2), (-10.4, -10.7)]
    driven = np.c_[np.linspace(-12.0, -3.2, 20), np.interp(np.linspace(-12.0, -3.2, 20),
                                                           [-12.0, -6.0, -3.2], [0.0, 0.7, 0.8])]
    return np.array(outer + inner + way_back), driven, np.array([0.3, -0.5])


def test_the_outer_rows_next_two_cones_make_no_gate_into_a_wide_hairpin() -> None:
    """At a hairpin too wide for a blind gate, the only edges on are the outer row's: its
    cone beside the car (passed since the way driven ends) is the row's, so the next one,
    where the row bends on to, is no cone of the other side, and the path ends at the
    hairpin's entry (the car stops there) instead of turning out through the outer row."""
    cones, driven, car = _wide_hairpin()
    colours = np.full(len(cones), UNKNOWN)
    path, _ = gate_search_path(cones, colours, car, -0.6, WIDTH_M, 0.0, driven)
    outer_gap_mid = 0.5 * (np.array([2.1, 2.0]) + np.array([5.2, 0.0]))
    assert np.min(np.hypot(*(path - outer_gap_mid).T)) > 1.0, path
    assert np.all(path[:, 0] < 2.5), path
