"""The hard layouts (simulator/hard_tracks.py): each way a planner fails has a track, and the
planner and controller drive each clean with perfect pose on the simulator's vehicle model;
the lap's seam is crossed lap after lap like any other point of the baseframe."""

from __future__ import annotations

import numpy as np
import pytest
from planner_closed_loop_helpers import run_closed_loop

from common.errors import TrackError
from common.messages import AsState
from orchestrator.config import AppConfig
from simulator.hard_tracks import HAIRPIN_RADIUS_M, HARD_LAYOUTS, hard_track
from simulator.tracks import load_track


@pytest.mark.parametrize("name", HARD_LAYOUTS)
def test_hard_layout_is_a_closed_track_of_its_width(name: str) -> None:
    track = load_track(f"hard:{name}")
    assert track.is_loop
    centre = track.centreline_xy_m
    step = np.hypot(*np.diff(np.r_[centre, centre[:1]], axis=0).T)
    assert np.all(np.abs(step - 0.5) < 0.01)  # closes exactly: no jump at the join
    widths = track.widths_m
    assert 2.8 < float(np.median(widths)) < 3.7
    assert len(track.cones_xy_m) > 40


def test_hairpin_is_the_rules_tightest() -> None:
    """FSD rules: hairpins of at least 9 m outer diameter; the centreline radius of a 3 m wide
    track is then 3 m."""
    track = load_track("hard:hairpins")
    assert 2.0 * (HAIRPIN_RADIUS_M + 1.5) == pytest.approx(9.0)
    kappa = np.abs(np.gradient(np.unwrap(np.arctan2(*np.gradient(track.centreline_xy_m,
                                                                  axis=0).T[::-1])), 0.5))
    assert float(np.max(kappa)) == pytest.approx(1.0 / HAIRPIN_RADIUS_M, rel=0.05)


def test_unknown_hard_layout_names_the_known_ones() -> None:
    with pytest.raises(TrackError, match="hairpins"):
        hard_track("no-such-layout")


@pytest.mark.parametrize("name", ["hairpins", "chicanes", "straights", "narrow", "seam-bend"])
@pytest.mark.slow
def test_hard_layout_driven_clean(name: str) -> None:
    """Two laps with perfect pose on the vehicle model, from a recorded exploration drive: no
    cone touched, never off the track, finished."""
    config = AppConfig()
    track = load_track(f"hard:{name}")
    result = run_closed_loop(config, track, laps=2, max_time_s=120.0, dynamic=True,
                             explore_waypoints=True)
    assert result.cones_hit == set()
    assert result.off_track == 0
    assert result.final_state == AsState.FINISHED, result.stop_reason
    assert len(result.lap_times_s) >= 1


def test_five_laps_cross_the_seam_with_continuous_progress_and_curvature() -> None:
    """hard:seam-bend puts the start line in a fast bend, where a baseframe joined badly would
    kink. Over five laps: one baseframe; the progress along it grows by v dt every step across
    each of the five seams as anywhere else; the curvature under the car and the steering
    change across the seam no more than they do elsewhere on the lap."""
    config = AppConfig()
    track = load_track("hard:seam-bend")
    result = run_closed_loop(config, track, laps=5, max_time_s=200.0, dynamic=True,
                             explore_waypoints=True)
    assert result.final_state == AsState.FINISHED, result.stop_reason
    assert result.cones_hit == set()
    trace = result.trace
    assert len(np.unique(trace[:, 5])) == 1, "the baseframe was rebuilt while racing"
    t, s, kappa, steer, v = trace[:, 0], trace[:, 1], trace[:, 2], trace[:, 3], trace[:, 4]
    length = float(trace[0, 6])
    ds = np.diff(s)
    seams = np.flatnonzero(ds < -0.5 * length)
    assert len(seams) == 5  # five crossings, one per lap
    ds[seams] += length  # arc length wraps at the seam: one lap on, the same point
    # progress in 0.1 s is the distance driven: v dt within the lateral and speed changes
    expected = 0.5 * (v[1:] + v[:-1]) * np.diff(t)
    assert np.all(np.abs(ds - expected) < 0.05 + 0.1 * expected)
    jumps_k = np.abs(np.diff(kappa))
    jumps_steer = np.abs(np.diff(steer))
    elsewhere = np.ones(len(ds), bool)
    for i in seams:
        elsewhere[max(i - 2, 0):i + 3] = False
    for i in seams:
        assert jumps_k[i] <= max(float(np.max(jumps_k[elsewhere])), 1e-3)
        assert jumps_steer[i] <= max(float(np.max(jumps_steer[elsewhere])), 1e-3)

