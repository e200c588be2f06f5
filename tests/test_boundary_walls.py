"""The lane's boundaries near the car as walls a manoeuvre may not leave through
(planner/boundary_walls.py)."""

from __future__ import annotations

import numpy as np

from common.car import CarConfig
from common.messages import ConeColour
from planner.baseframe import SplineBaseframe
from planner.boundary_walls import MAX_GAP_M, boundary_walls, leaves_through
from planner.config import PlannerConfig
from planner.manoeuvres import ManoeuvreGenerator

BLUE, YELLOW, UNKNOWN = int(ConeColour.BLUE), int(ConeColour.YELLOW), int(ConeColour.UNKNOWN)


def _lane(spacing_m: float = 3.9, half_width_m: float = 1.5
          ) -> tuple[SplineBaseframe, np.ndarray, np.ndarray]:
    """A straight lane along +x from x = -5: its middle as the frame, its cones and colours."""
    x = np.arange(-4.0, 30.0, spacing_m)
    cones = np.vstack([np.stack([x, np.full_like(x, half_width_m)], axis=1),
                       np.stack([x, np.full_like(x, -half_width_m)], axis=1)])
    colours = np.array([BLUE] * len(x) + [YELLOW] * len(x))
    frame = SplineBaseframe(np.stack([np.linspace(-5.0, 35.0, 41), np.zeros(41)], axis=1),
                            False, step_m=0.25)
    return frame, cones, colours


def test_walls_run_along_each_side_with_the_lane_on_their_right() -> None:
    frame, cones, colours = _lane()
    walls = boundary_walls(frame, cones, colours, (0.0, 0.0))
    assert len(walls) > 0
    left = walls[walls[:, 0, 1] > 0]
    right = walls[walls[:, 0, 1] < 0]
    assert len(left) and len(right)
    assert np.allclose(left[:, :, 1], 1.5) and np.all(left[:, 1, 0] > left[:, 0, 0])
    assert np.allclose(right[:, :, 1], -1.5) and np.all(right[:, 1, 0] < right[:, 0, 0])
    # only cones near the car make walls
    assert np.all(np.abs(walls[:, :, 0]) <= 12.0 + 1e-9)


def test_leaving_the_lane_is_caught_coming_back_is_not() -> None:
    frame, cones, colours = _lane()
    walls = boundary_walls(frame, cones, colours, (0.0, 0.0))
    x = np.linspace(0.0, 6.0, 25)
    out = np.stack([x, np.linspace(0.0, 2.5, 25)], axis=1)  # out between two left cones
    back = np.stack([x, np.linspace(2.5, 0.0, 25)], axis=1)  # from outside into the lane
    along = np.stack([x, np.full_like(x, 0.8)], axis=1)  # in the lane, near its side
    out_right = np.stack([x, np.linspace(0.0, -2.5, 25)], axis=1)
    got = leaves_through(np.stack([out, back, along, out_right]), walls)
    assert got.tolist() == [True, False, False, True]


def test_no_wall_from_a_wrong_colour_a_wide_gap_or_no_colours() -> None:
    frame, cones, colours = _lane()
    swapped = np.where(colours == BLUE, YELLOW, BLUE)  # each colour on the other side
    assert len(boundary_walls(frame, cones, swapped, (0.0, 0.0))) == 0
    unknown = np.full_like(colours, UNKNOWN)  # the camera dead
    assert len(boundary_walls(frame, cones, unknown, (0.0, 0.0))) == 0
    sparse_frame, sparse, sparse_colours = _lane(spacing_m=MAX_GAP_M + 1.0)
    assert len(boundary_walls(sparse_frame, sparse, sparse_colours, (0.0, 0.0))) == 0


def test_a_row_of_the_next_lane_across_the_infield_leaves_no_gap_in_the_wall() -> None:
    # hard:hairpins: the next lane's blue row 3 m across the infield from the lane's own, its
    # cones between the lane's in order along the path. Out between two of the lane's cones
    # is still leaving the lane (autocross seed 10: a manoeuvre 2.5 m to the left went out
    # there and hit the next cone).
    frame, cones, colours = _lane()
    x = np.arange(-2.0, 30.0, 3.9)
    beyond = np.stack([x, np.full_like(x, 4.5)], axis=1)
    cones = np.vstack([cones, beyond])
    colours = np.r_[colours, np.full(len(x), BLUE)]
    walls = boundary_walls(frame, cones, colours, (0.0, 0.0))
    across = np.abs(walls[:, 1, 1] - walls[:, 0, 1]) > 1.0
    assert not np.any(across)  # no wall runs from one row to the other
    x_path = np.linspace(0.0, 6.0, 25)
    out = np.stack([x_path, np.linspace(0.0, 2.5, 25)], axis=1)  # out, into the infield
    assert leaves_through(out[None], walls).tolist() == [True]


def test_a_manoeuvre_out_between_the_cones_is_refused_and_never_the_stop_path() -> None:
    frame, cones, colours = _lane()
    config, car = PlannerConfig(), CarConfig()
    # an obstacle in the middle of the lane 8 m ahead: only a way round it is clear of cones
    blocked = np.vstack([cones, [[8.0, 0.0]]])
    walls = boundary_walls(frame, cones, colours, (0.0, 0.0))
    without = ManoeuvreGenerator(config, car)
    cands, best = without.generate(frame, 5.0, 0.0, 0.0, 3.0, blocked, None)
    assert best >= 0 and abs(cands[best].offset_m) > 1.5  # out of the 3 m lane, as before
    within = ManoeuvreGenerator(config, car)
    cands, best = within.generate(frame, 5.0, 0.0, 0.0, 3.0, blocked, None, walls=walls)
    assert best < 0  # nothing in the lane clears it: the car stops
    assert within.rejections and any(k.endswith("boundary") for k in within.rejections)
    stop = cands[within.stop_path(cands)]
    assert not leaves_through(stop.xy_m[None], walls)[0]
