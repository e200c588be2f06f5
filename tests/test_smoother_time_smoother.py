"""Time smoother (seed 002, 7.2-7.4): matching, decay rules, and the straight-drive acceptance."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import linear_sum_assignment

from common.messages import ConeDetection
from mapper.config import ObjectFilterConfig, SmootherConfig
from mapper.mapper import Mapper
from mapper.object_filter import ObjectFilter, localise_objects
from mapper.time_smoother import TimeSmoother
from orchestrator.config import AppConfig
from support import drives

SIZE = np.array([[0.228, 0.325]])


def test_match_averages_and_raises_confidence_to_the_limit() -> None:
    cfg = SmootherConfig()
    ts = TimeSmoother(cfg)
    pose = (0.0, 0.0, 0.0)
    ts.update(np.array([[5.0, 1.0]]), SIZE, pose)
    ts.update(np.array([[5.2, 1.0]]), SIZE, pose)
    assert len(ts) == 1
    assert math.isclose(ts.xy_m[0, 0], 5.1, abs_tol=1e-9)  # running mean of two
    for _ in range(30):
        ts.update(np.array([[5.1, 1.0]]), SIZE, pose)
    assert ts.confidence[0] == cfg.conf_limit - cfg.confidence_decay
    assert ts.match_count[0] == 31


def test_size_mismatch_makes_a_new_object() -> None:
    ts = TimeSmoother(SmootherConfig())
    ts.update(np.array([[5.0, 1.0]]), SIZE, (0.0, 0.0, 0.0))
    ts.update(np.array([[5.1, 1.0]]), np.array([[0.228, 0.325 * 1.8]]), (0.0, 0.0, 0.0))
    assert len(ts) == 2


def test_unmatched_object_decays_and_is_deleted() -> None:
    cfg = SmootherConfig()
    ts = TimeSmoother(cfg)
    ts.update(np.array([[5.0, 1.0]]), SIZE, (0.0, 0.0, 0.0))
    frames = 0
    while len(ts) and frames < 10:
        ts.update(np.zeros((0, 2)), None, (0.0, 0.0, 0.0))
        frames += 1
    # initial 2, -1 per frame (also the creating frame), deleted below zero.
    assert frames == 2


def test_no_decay_outside_the_detection_range_for_confirmed_objects() -> None:
    cfg = SmootherConfig()
    ts = TimeSmoother(cfg)
    for _ in range(5):
        ts.update(np.array([[5.0, 1.0], [8.0, -1.0]]), np.repeat(SIZE, 2, 0), (0.0, 0.0, 0.0))
    # A one-off false object far behind the future pose.
    ts.update(np.array([[5.0, 1.0], [8.0, -1.0], [9.0, 3.0]]), np.repeat(SIZE, 3, 0),
              (0.0, 0.0, 0.0))
    conf = ts.confidence[:2].copy()
    far_pose = (200.0, 0.0, 0.0)  # everything is behind and out of range
    for _ in range(50):
        ts.update(np.zeros((0, 2)), None, far_pose)
    assert len(ts) == 2  # the confirmed cones stay; the unconfirmed one died
    assert np.allclose(ts.confidence, conf)


def test_object_filter_and_localisation() -> None:
    of = ObjectFilter(ObjectFilterConfig())
    cones = [ConeDetection(0.0, 0.5, 0.0), ConeDetection(0.0, 5.0, 0.0),
             ConeDetection(0.0, 30.0, 0.0), ConeDetection(0.0, 5.0, 1.0, height_m=2.0)]
    kept = of.filter(cones)
    assert len(kept) == 1
    assert of.rejects == {"too_near": 1, "too_far": 1, "bad_height": 1}
    xy = localise_objects(kept, 1.0, 2.0, math.pi / 2)
    assert np.allclose(xy, [[1.0, 7.0]])


@pytest.mark.shared_data(drives.ACCELERATION)
def test_straight_drive_acceptance() -> None:
    """Seed 002, 7.4: a straight drive between two rows of cones (the acceleration track), the
    simulated LiDAR's detections with 10 % of them missed and 5 % false ones added: kept objects
    <= 1.05x the true cones seen (twice), >= 98 % of those kept."""
    cfg = AppConfig()
    cfg.mapper.backend = "smoother"
    drive, labels = drives.with_lidar_errors(drives.drive(drives.ACCELERATION, seed=3),
                                             miss=0.10, false_fraction=0.05, seed=3)
    mapper = Mapper(cfg.mapper, cfg.car)
    state = None
    for now, batch in drive.batches():
        state = mapper.update(batch, now)
    assert state is not None
    counts = np.zeros(len(drive.cones_xy_m), int)
    false_total = 0
    for idx in labels:
        np.add.at(counts, idx[idx >= 0], 1)
        false_total += int(np.count_nonzero(idx < 0))
    seen = drive.cones_xy_m[counts >= 2]  # a cone seen once is not yet confirmed by anyone
    kept = state.cones.xy_m
    dist = np.linalg.norm(kept[:, None, :] - seen[None, :, :], axis=2)
    rows, cols = linear_sum_assignment(np.where(dist < 1.0, dist, 1e6))
    matched = int(np.count_nonzero(dist[rows, cols] < 1.0))
    raw = mapper.backend.smoother.raw_objects_total
    print(f"raw objects {raw} (false {false_total}) -> kept {len(kept)}; true cones seen "
          f"{len(seen)}, matched {matched}")
    assert false_total > 20
    assert len(seen) >= 40
    assert len(kept) <= 1.05 * len(seen)
    assert matched >= 0.98 * len(seen)
