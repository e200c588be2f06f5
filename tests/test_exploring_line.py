"""The line driven where the gates' path bends beyond the lock (planner/exploring_line.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from common.car import CarConfig
from common.messages import ConeColour
from planner.baseframe import SplineBaseframe
from planner.config import PlannerConfig
from planner.exploring_line import bends_beyond, steerable_frame
from planner.manoeuvres import ManoeuvreGenerator
from planner.track_model import most_room_offsets
from simulator.hard_tracks import HAIRPIN_RADIUS_M, first_arc, hard_track
from support.exploring_frames import gates_frame

CONFIG = PlannerConfig()
CAR = CarConfig()
LIMIT_1PM = ManoeuvreGenerator(CONFIG, CAR).kappa_max_1pm
SEEN_M = 20.0
"""The camera's range: the cones the car has seen."""


def _body_clearance_m(frame: SplineBaseframe, cones: np.ndarray, bend_centre: np.ndarray
                      ) -> float:
    """Least distance (m) from a cone's centre to the car's body, its rear axle on the frame
    and its heading the frame's, round the hairpin (from 1 m before its arc begins; beyond,
    the path through the gates seen goes on along the straight, or without colours across
    the infield, which is not what this line is about)."""
    front, rear = CAR.length_m - CAR.rear_overhang_m, -CAR.rear_overhang_m
    least = math.inf
    in_bend = frame.xy_m[:, 0] > bend_centre[0] - 1.0
    for (x, y), yaw in zip(frame.xy_m[in_bend], frame.heading_rad[in_bend], strict=True):
        d = cones - (x, y)
        along = d[:, 0] * math.cos(yaw) + d[:, 1] * math.sin(yaw)
        across = -d[:, 0] * math.sin(yaw) + d[:, 1] * math.cos(yaw)
        out_x = np.maximum(np.maximum(rear - along, along - front), 0.0)
        out_y = np.maximum(np.abs(across) - CAR.width_m / 2.0, 0.0)
        least = min(least, float(np.min(np.hypot(out_x, out_y))))
    return least


@pytest.fixture(scope="module")
def hairpin() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The first rules-minimum hairpin of ``hard:hairpins`` (9 m outer diameter, 3 m wide):
    its cones (N, 2), their colours (N,), the car's poses (x, y, yaw) (P, 3) on the centreline
    every 0.5 m from 6 m before the arc to 3 m into it, and the bend's centre (2,)."""
    track = hard_track("hairpins")
    first, heading, bend_centre = first_arc(track)
    at = np.arange(first - 12, first + 7)  # samples are 0.5 m apart
    poses = np.column_stack([track.centreline_xy_m[at], heading[at]])
    return (np.asarray(track.cones_xy_m), np.asarray(track.colours), poses, bend_centre)


def _equal_room_radius_m() -> float:
    """The rear axle's distance (m) from the hairpin's centre at which the body has as much
    room to the inner boundary as to the outer one, both taken as arcs (the boundary through
    the cones is their chords, which take some room on the outside)."""
    half_w, front = CAR.width_m / 2.0, CAR.length_m - CAR.rear_overhang_m
    inner, outer = HAIRPIN_RADIUS_M - 1.5, HAIRPIN_RADIUS_M + 1.5
    radii = np.linspace(2.0, 3.5, 3001)
    # what the front corner swings out beyond half the width on a bend of that radius
    swing = front**2 / (np.hypot(radii + half_w, front) + radii + half_w)
    return float(radii[np.argmin(np.abs((radii - inner - half_w)
                                        - (outer - radii - half_w - swing)))])


@pytest.mark.parametrize("colours_known", [True, False])
def test_a_hairpin_is_driven_where_the_body_has_room(hairpin, colours_known) -> None:
    cones_all, colours_all, poses, bend_centre = hairpin
    if not colours_known:  # the camera dead: sides from where the cones lie
        colours_all = np.full(len(cones_all), int(ConeColour.UNKNOWN))
    low = HAIRPIN_RADIUS_M - 1.5 + CAR.width_m / 2.0 + CONFIG.cone_radius_m
    high = _equal_room_radius_m()
    gains, sharp = [], 0
    for x, y, yaw in poses:
        seen = np.hypot(cones_all[:, 0] - x, cones_all[:, 1] - y) < SEEN_M
        cones, colours = cones_all[seen], colours_all[seen]
        gates = gates_frame(cones, colours, x, y, yaw)
        sharp += bends_beyond(gates, 0.0, LIMIT_1PM)
        steered = steerable_frame(gates, cones, colours, (x, y), CAR, CONFIG, LIMIT_1PM)
        if steered is None:  # its sharpest bend is no gentler: the gates' path is kept
            continue
        assert np.max(np.abs(steered.curvature_1pm)) < np.max(np.abs(gates.curvature_1pm))
        # round the bend the rear axle runs inside the middle (3 m from the centre), between
        # the inner cones plus half the car and a cone's radius, and the equal-room radius
        rel = steered.xy_m - bend_centre
        radius = float(np.median(np.hypot(*rel[rel[:, 0] > 0.5].T)))
        assert low < radius < high
        # and the body keeps more than a cone's radius + 0.1 m from the cones there
        after = _body_clearance_m(steered, cones, bend_centre)
        assert after >= CONFIG.cone_radius_m + 0.1
        gains.append(after - _body_clearance_m(gates, cones, bend_centre))
    # the premise: the gates' path through the hairpin bends beyond the lock on the way in
    assert sharp >= len(poses) // 2
    # the line is taken at a good share of those plans, and gains room on the whole
    assert len(gains) >= len(poses) // 4
    assert np.mean(gains) > 0.05


def test_a_frame_within_the_lock_is_kept() -> None:
    # a lane 3.5 m wide bending on 12 m: well within the lock
    angle = np.linspace(0.0, 1.5, 60)
    centre = np.stack([12.0 * np.sin(angle), 12.0 * (1.0 - np.cos(angle))], axis=1)
    left = np.stack([10.25 * np.sin(angle), 12.0 - 10.25 * np.cos(angle)], axis=1)[::5]
    right = np.stack([13.75 * np.sin(angle), 12.0 - 13.75 * np.cos(angle)], axis=1)[::5]
    cones = np.vstack([left, right])
    colours = np.array([int(ConeColour.BLUE)] * len(left) + [int(ConeColour.YELLOW)] * len(right))
    frame = SplineBaseframe(centre, False, step_m=CONFIG.baseframe_step_m)
    assert not bends_beyond(frame, 0.0, LIMIT_1PM)
    assert steerable_frame(frame, cones, colours, (0.0, 0.0), CAR, CONFIG, LIMIT_1PM) is None


def test_most_room_on_a_straight_lane() -> None:
    x = np.linspace(0.0, 10.0, 21)
    centre = np.stack([x, np.zeros_like(x)], axis=1)
    normals = np.tile([0.0, 1.0], (len(x), 1))
    dense = np.linspace(-5.0, 15.0, 201)
    left = np.stack([dense, np.full_like(dense, 1.5)], axis=1)
    right = np.stack([dense, np.full_like(dense, -1.5)], axis=1)
    zero = np.zeros(len(x))
    assert np.allclose(most_room_offsets(centre, normals, left, right, zero, zero, 2.0), 0.0,
                       atol=0.026)
    # a 1 m margin on the left: equal room 0.5 m right of the middle
    pushed = most_room_offsets(centre, normals, left, right, zero + 1.0, zero, 2.0)
    assert np.allclose(pushed, -0.5, atol=0.026)
