"""The gate search over the cones' triangulation: it keeps to the car's own stretch of track
where another stretch runs close beside it, and it goes round a hairpin."""

from __future__ import annotations

import numpy as np
import pytest

from common.messages import ConeColour
from common.polyline import nearest_on_polyline, resample
from planner.exploration_path import ENTRY_BEHIND_M, exploration_path
from planner.gate_search import gate_search_path

BLUE, YELLOW = int(ConeColour.BLUE), int(ConeColour.YELLOW)
UNKNOWN = int(ConeColour.UNKNOWN)
HALF_WIDTH_M = 1.75


def _offset(centre: np.ndarray, offset_m: float) -> np.ndarray:
    """The polyline ``centre`` (N, 2) moved ``offset_m`` to its left."""
    d = np.gradient(centre, axis=0)
    d /= np.hypot(d[:, 0], d[:, 1])[:, None]
    return centre + offset_m * np.c_[-d[:, 1], d[:, 0]]


def _lane_turning_left() -> np.ndarray:
    """A lane's centreline from the origin along +x for 12 m, then a 60 degree left bend of
    8 m radius, then straight on (m)."""
    straight = np.c_[np.linspace(0.0, 12.0, 25), np.zeros(25)]
    a = np.linspace(0.0, np.pi / 3.0, 30)[1:]
    bend = np.c_[12.0 + 8.0 * np.sin(a), 8.0 - 8.0 * np.cos(a)]
    out = bend[-1] + np.linspace(0.0, 10.0, 21)[1:, None] * np.array([np.cos(a[-1]),
                                                                          np.sin(a[-1])])
    return resample(np.r_[straight, bend, out], 0.1, False)


def _cones_along(line: np.ndarray, spacing_m: float, first_m: float = 1.0) -> np.ndarray:
    step = line[1] - line[0]
    n = int(round(spacing_m / float(np.hypot(*step))))
    return line[int(round(first_m / float(np.hypot(*step))))::n]


def _thin_infield() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The car's lane turning left, and the inner (yellow) boundary of another stretch of
    track running straight on 1.6 m beside its yellow side (an infield like the community
    layout 'thin'): cones (N, 2), colours (N,) and the lane's centreline."""
    centre = _lane_turning_left()
    left = _cones_along(_offset(centre, HALF_WIDTH_M), 4.0)
    right = _cones_along(_offset(centre, -HALF_WIDTH_M), 4.0, first_m=3.0)
    x = np.arange(2.0, 32.0, 4.0)
    other = np.c_[x, np.full(len(x), -HALF_WIDTH_M - 1.6)]
    cones = np.r_[left, right, other]
    colours = np.r_[np.full(len(left), BLUE), np.full(len(right) + len(other), YELLOW)]
    return cones, colours, centre


def test_the_search_keeps_to_its_own_stretch_beside_another() -> None:
    cones, colours, centre = _thin_infield()
    path, bounding = gate_search_path(cones, colours, np.zeros(2), 0.0, 2.0 * HALF_WIDTH_M)
    assert len(path) >= 8
    distance, _, _, _ = nearest_on_polyline(path, centre, False)
    assert np.all(distance < 0.35)
    # it follows the lane round its bend, and never pairs with the other stretch's cones
    assert path[-1, 1] > 8.0
    n_lane = len(cones) - 8
    assert not bounding[n_lane:].any()


def test_exploration_path_follows_the_lane_past_the_other_stretch() -> None:
    cones, colours, centre = _thin_infield()
    path = exploration_path(cones, colours, (0.0, 0.0), 0.0, track_width_m=2.0 * HALF_WIDTH_M)
    distance, _, _, _ = nearest_on_polyline(path, centre, False)
    assert path[-1, 1] > 8.0
    assert np.all(distance < 0.5)


def test_the_search_goes_round_a_hairpin() -> None:
    """The rules' tightest hairpin: 4.5 m outer radius, 3 m wide, so the inner side is a
    1.5 m radius arc of a few cones: the path rounds it on the centreline (3 m radius)."""
    a = np.linspace(-np.pi / 2.0, np.pi / 2.0, 13)
    centre_arc = np.c_[10.0 + 3.0 * np.cos(a), 3.0 + 3.0 * np.sin(a)]
    entry = np.c_[np.linspace(0.0, 10.0, 21)[:-1], np.zeros(20)]
    exit_ = np.c_[np.linspace(10.0, 0.0, 21)[1:], np.full(20, 6.0)]
    centre = resample(np.r_[entry, centre_arc, exit_], 0.1, False)
    outer = np.r_[np.c_[np.arange(1.0, 10.0, 3.0), np.full(3, -1.5)],
                  np.c_[10.0 + 4.5 * np.cos(a[::2]), 3.0 + 4.5 * np.sin(a[::2])],
                  np.c_[np.arange(9.0, 0.0, -3.0), np.full(3, 7.5)]]
    inner = np.r_[np.c_[np.arange(1.0, 10.0, 3.0), np.full(3, 1.5)],
                  np.c_[10.0 + 1.5 * np.cos(a[::4]), 3.0 + 1.5 * np.sin(a[::4])],
                  np.c_[np.arange(9.0, 0.0, -3.0), np.full(3, 4.5)]]
    # a left hairpin: the inner cones are the left (blue) side
    cones = np.r_[inner, outer]
    colours = np.r_[np.full(len(inner), BLUE), np.full(len(outer), YELLOW)]
    path, _ = gate_search_path(cones, colours, np.zeros(2), 0.0, 3.0)
    distance, _, _, _ = nearest_on_polyline(path, centre, False)
    assert path[-1, 1] > 5.0 and path[-1, 0] < 8.0  # round the hairpin and out of it
    assert np.all(distance < 0.6)


@pytest.mark.parametrize("side", [1.0, -1.0])
@pytest.mark.parametrize("beyond_m", [3.0, 6.0, 7.0, 9.3])
@pytest.mark.parametrize("off_m", [-0.45, 0.0, 0.45])
def test_a_rows_last_cone_and_an_uncoloured_cone_on_its_line_are_no_gate(
        side: float, beyond_m: float, off_m: float) -> None:
    """A coloured lane whose cones end at 60 m, and one cone not coloured yet ``beyond_m``
    further on (near) the line of one of its rows: it may be that row's next cone, or the
    next but one, so the edge from that row's last cone to it runs along a boundary and is no
    gate. (Up to 9.3 m beyond, within the longest gate, the path ended on the row's line,
    3.3 m off the lane's centre once marched on.) A diagonal gate from the other row's last
    cone to it leaves the path inside the lane."""
    x = np.arange(-6.0, 60.1, 3.0)
    lone = np.array([60.0 + beyond_m, side * (HALF_WIDTH_M + off_m)])
    cones = np.r_[np.c_[x, np.full(len(x), HALF_WIDTH_M)],
                  np.c_[x, np.full(len(x), -HALF_WIDTH_M)], lone[None, :]]
    colours = np.r_[np.full(len(x), BLUE), np.full(len(x), YELLOW), [UNKNOWN]]
    path, _ = gate_search_path(cones, colours, np.array([50.0, 0.0]), 0.0, 2.0 * HALF_WIDTH_M)
    # as the planner asks in the closed loop: the car at the lane's last gate, its path from
    # the gate behind it, the way it drove (up to a few metres back) known
    driven = np.c_[np.linspace(20.0, 56.0, 37), np.zeros(37)]
    marched = exploration_path(cones, colours, (59.2, 0.0), 0.0,
                               track_width_m=2.0 * HALF_WIDTH_M, behind_m=ENTRY_BEHIND_M,
                               driven_xy_m=driven)
    assert path[-1, 0] >= 60.0  # through the lane's last gate
    for points in (path, marched):  # inside the lane, well off both its rows
        assert np.all(np.abs(points[:, 1]) < 0.5 * HALF_WIDTH_M)


def test_no_gate_ahead_is_the_car_alone() -> None:
    cones = np.array([[5.0, 1.75], [9.0, 1.75], [13.0, 1.75]])
    path, bounding = gate_search_path(cones, np.full(3, BLUE), np.zeros(2), 0.0, 3.5)
    assert path.shape == (1, 2) and not bounding.any()


def test_without_colours_a_cone_keeps_its_side() -> None:
    """Camera dead: every cone of unknown colour. Two cones of one boundary (4 m apart) would
    make a gate of about the track's width; a cone once on the path's right stays on its right,
    so the path still keeps to its lane and round its bend."""
    cones, _, centre = _thin_infield()
    unknown = np.full(len(cones), UNKNOWN)
    path, _ = gate_search_path(cones, unknown, np.zeros(2), 0.0, 2.0 * HALF_WIDTH_M)
    distance, _, _, _ = nearest_on_polyline(path, centre, False)
    assert path[-1, 1] > 8.0
    assert np.all(distance < 0.35)


def test_without_colours_the_path_ends_where_its_lane_is_unmapped() -> None:
    """Camera dead, FSG's bottom-left lane: the lane's cones are mapped 17 m ahead, and beside
    it, 7.5 m across the infield, another stretch runs back. An edge across the infield is as
    long as a bend's diagonal gate, and the next stretch's gates beyond it would reward the
    path for its reach: without colours such a wide edge is no gate, and the path ends in its
    own lane."""
    x = np.arange(0.0, 17.0, 4.0)
    lane = np.r_[np.c_[x, np.full(len(x), HALF_WIDTH_M)],
                 np.c_[x + 2.0, np.full(len(x), -HALF_WIDTH_M)]]
    xo = np.arange(-2.0, 30.0, 4.0)
    infield_m = 7.5
    other = np.r_[np.c_[xo, np.full(len(xo), -HALF_WIDTH_M - infield_m)],
                  np.c_[xo + 2.0, np.full(len(xo), -3.0 * HALF_WIDTH_M - infield_m)]]
    cones = np.r_[lane, other]
    path, bounding = gate_search_path(cones, np.full(len(cones), UNKNOWN), np.array([-1.0, 0.0]),
                                      0.0, 2.0 * HALF_WIDTH_M)
    assert path[-1, 0] > 14.0
    assert np.all(np.abs(path[:, 1]) < HALF_WIDTH_M)
    assert not bounding[len(lane):].any()


def test_same_coloured_cones_are_never_a_gate() -> None:
    cones, _, _ = _thin_infield()
    path_blue, _ = gate_search_path(cones, np.full(len(cones), BLUE), np.zeros(2), 0.0,
                                    2.0 * HALF_WIDTH_M)
    assert len(path_blue) == 1


def test_a_ring_of_close_cones_keeps_the_path_round_its_middle() -> None:
    """A rules-minimum hairpin as a whole circle (inner cones on 1.7 m, 0.7 m apart; outer on
    4.7 m, 1 m apart): the centre points stand some 0.4 m apart and are merged in runs, never
    into one point that takes the whole bend with it (the path cut 0.9 m inside the middle,
    onto the inner cones)."""
    centre = np.array([0.0, 3.2])
    inner_a = np.linspace(0.0, 2.0 * np.pi, 15, endpoint=False)
    outer_a = np.linspace(0.0, 2.0 * np.pi, 30, endpoint=False)
    inner = centre + 1.7 * np.c_[np.sin(inner_a), -np.cos(inner_a)]
    outer = centre + 4.7 * np.c_[np.sin(outer_a), -np.cos(outer_a)]
    start = np.array([0.0, 0.0])  # on the middle (3.2 m), heading +x: the car turns left
    ahead = lambda xy: (xy[:, 0] > -0.5) & (xy[:, 1] < 6.5)  # noqa: E731 (half a lap seen)
    xy = np.r_[inner[ahead(inner)], outer[ahead(outer)]]
    col = np.r_[np.full(int(ahead(inner).sum()), BLUE), np.full(int(ahead(outer).sum()), YELLOW)]
    path, _ = gate_search_path(xy, col, start, 0.0, 3.5)
    assert len(path) >= 6
    radius = np.hypot(*(path[1:] - centre).T)
    assert np.all(np.abs(radius - 3.2) < 0.35), radius
    assert float(np.max(np.hypot(*np.diff(path, axis=0).T))) < 2.5


def test_gates_the_car_drove_through_are_never_ahead() -> None:
    """Without colours, a gap at a hairpin's end can lead the search back up the way in (FSG's
    bottom hairpin, camera dead): the gates the car's trace crossed are behind it. Here a car
    turned round in a lane of unknown cones sees the lane it came down as the way ahead, until
    its trace says it came that way; the same gates crossed the same way (a lap later) stay
    the way ahead."""
    ys = np.arange(0.0, 30.01, 3.0)
    xy = np.r_[np.c_[np.full_like(ys, 1.75), ys], np.c_[np.full_like(ys, -1.75), ys]]
    col = np.zeros(len(xy), np.int64)
    car, yaw = np.array([0.0, 1.0]), np.pi / 2.0  # at the lane's south end, facing north
    came = np.c_[np.zeros(30), np.linspace(30.0, 2.0, 30)]  # drove it southwards

    free, _ = gate_search_path(xy, col, car, yaw, 3.5)
    assert len(free) >= 4 and free[-1][1] > 20.0  # back up the lane: it looks like track
    behind, _ = gate_search_path(xy, col, car, yaw, 3.5, driven_xy_m=came)
    assert behind[-1][1] < 6.0  # no further than the car's own cell: the rest is behind it
    # the next lap crosses the same gates the same way: that is the way ahead
    again, _ = gate_search_path(xy, col, np.array([0.0, 29.0]), -np.pi / 2.0, 3.5,
                                driven_xy_m=came)
    assert len(again) >= 4 and again[-1][1] < 10.0


def test_the_trace_blocks_only_the_edges_it_crossed() -> None:
    from scipy.spatial import Delaunay

    from planner.gate_rows import edges_crossed

    xy = np.array([[0.0, 0.0], [4.0, 0.0], [0.0, 4.0], [4.0, 4.0]])
    tri = Delaunay(xy)
    crossed = edges_crossed(xy, tri.simplices, np.array([[2.0, -1.0], [2.0, 1.0]]))
    assert crossed == {(0, 1): 1.0}  # the bottom edge only, crossed towards its left
    assert edges_crossed(xy, tri.simplices, np.array([[-1.0, -1.0], [-1.0, 5.0]])) == {}


def test_no_gate_spans_an_infield_past_the_mapped_end_of_a_row(monkeypatch) -> None:
    """hard:corner-start's long straights: two lanes side by side (blue 4.5 m and yellow 7.5 m
    up, blue 1.5 m and yellow -1.5 m down, driven the other way), mapped as far as each row's
    cones came into view. The edge from the upper lane's last yellow cone down to the lower
    lane's last blue one has the upper row's last blue cone standing in its middle: no gate
    (with it the path turned across the infield and the car, going wide, hit the outer row)."""
    xs = -np.arange(0.0, 49.0, 4.38) - 25.86
    upper_blue = np.c_[xs + 0.62, np.full(len(xs), 4.55)]
    upper_yellow = np.c_[xs, np.full(len(xs), 7.55)]
    lower_blue = np.c_[xs - 0.9, np.full(len(xs), 1.55)]
    lower_yellow = np.c_[xs - 2.5, np.full(len(xs), -1.45)]
    xy = np.r_[upper_blue, upper_yellow, lower_blue, lower_yellow]
    # driven along -x: the upper lane's blue row is on the car's left, its yellow on its right
    col = np.r_[np.full(len(upper_blue), BLUE), np.full(len(upper_yellow), YELLOW),
                np.full(len(lower_blue), BLUE), np.full(len(lower_yellow), YELLOW)]
    start = np.array([upper_blue[-3, 0] + 1.0, 6.05])
    pts, _ = gate_search_path(xy, col, start, np.pi, 3.5, 2.5, None)
    assert len(pts) >= 3
    assert np.all(pts[:, 1] > 5.0), pts  # never across the upper lane's inner row
    import planner.gate_search as gs

    monkeypatch.setattr(gs, "CONE_IN_GATE_FRACTION", 0.0)  # without the rule it did
    pts, _ = gate_search_path(xy, col, start, np.pi, 3.5, 2.5, None)
    assert np.any(pts[:, 1] < 5.0), pts


def test_without_colours_the_march_stops_at_a_lone_cone() -> None:
    """Past the last gate of both sides only the left boundary is mapped (the right one is
    hidden, round a bend). Coloured, the left cones say which side they bound and the march
    goes on half a track width inside them; without colours their side is a guess, and the
    path ends at the last gate of two cones."""
    x = np.arange(0.0, 9.0, 4.0)
    lane = np.r_[np.c_[x, np.full(len(x), HALF_WIDTH_M)], np.c_[x, np.full(len(x), -HALF_WIDTH_M)]]
    xl = np.arange(12.0, 25.0, 4.0)
    cones = np.r_[lane, np.c_[xl, np.full(len(xl), HALF_WIDTH_M)]]
    sides = np.r_[np.full(len(x), BLUE), np.full(len(x), YELLOW), np.full(len(xl), BLUE)]
    coloured = exploration_path(cones, sides, (-1.0, 0.0), 0.0, track_width_m=3.5)
    blind = exploration_path(cones, np.full(len(cones), UNKNOWN), (-1.0, 0.0), 0.0,
                             track_width_m=3.5)
    assert coloured[-1, 0] > 18.0 and np.all(np.abs(coloured[:, 1]) < HALF_WIDTH_M)
    assert blind[-1, 0] < 12.0 and np.all(np.abs(blind[:, 1]) < HALF_WIDTH_M)



def _staggered_straight() -> tuple[np.ndarray, np.ndarray]:
    """A straight lane along +x, 3.5 m wide, its blue cones every 5 m from x = 0 and its
    yellow ones every 5 m from x = 2.5 (each gate at a slant): cones (N, 2), colours (N,)."""
    left = np.c_[np.arange(-10.0, 40.0, 5.0), np.full(10, HALF_WIDTH_M)]
    right = np.c_[np.arange(-7.5, 40.0, 5.0), np.full(10, -HALF_WIDTH_M)]
    return np.r_[left, right], np.r_[np.full(10, BLUE), np.full(10, YELLOW)]


def test_a_car_off_the_middle_starts_its_path_at_the_gate_it_came_through() -> None:
    # The car 0.6 m left of the middle, heading a little back towards it, at every 0.25 m of
    # two cone spacings: the path always starts on the middle (the midpoint of the gate the
    # car came through), never at the car itself. Started at the car, the car would sit on
    # its own path in one plan and 0.6 m off the gate's path in the next: the planner's
    # chosen offset would jump with it.
    cones, colours = _staggered_straight()
    for x_m in np.arange(0.0, 10.0, 0.25):
        path = exploration_path(cones, colours, (float(x_m), 0.6), -0.05,
                                track_width_m=2.0 * HALF_WIDTH_M, behind_m=ENTRY_BEHIND_M)
        assert len(path) >= 4, x_m
        assert abs(path[0, 1]) < 1e-9, (x_m, path[0])  # on the middle, not at the car
        assert -5.0 <= path[0, 0] - x_m <= 0.5, (x_m, path[0])  # the gate beside or behind
