"""Map and pose evaluation against ground truth, and the NEES helpers."""

from __future__ import annotations

import math

import numpy as np
import pytest

from common.messages import ConeColour, ConeMap
from mapper.evaluation import (
    evaluate_map,
    match_cones,
    nees,
    nees_band,
    nees_fraction_in_band,
    pose_errors,
)


def _map(xy: np.ndarray, colours: np.ndarray) -> ConeMap:
    n = xy.shape[0]
    return ConeMap(xy, np.tile(np.eye(2) * 1e-4, (n, 1, 1)), colours, np.ones(n, np.int64),
                   np.ones(n), np.arange(n))


def test_evaluate_map_counts_matches_false_and_missed() -> None:
    truth = np.array([[0.0, 0.0], [5.0, 0.0], [10.0, 0.0], [15.0, 0.0]])
    colours = np.array([ConeColour.BLUE, ConeColour.BLUE, ConeColour.YELLOW, ConeColour.YELLOW])
    est = np.array([[0.1, 0.0], [5.0, -0.2], [10.0, 0.0], [30.0, 0.0], [14.0, 0.0]])
    est_colours = np.array([ConeColour.BLUE, ConeColour.YELLOW, ConeColour.YELLOW,
                            ConeColour.BLUE, ConeColour.BLUE])
    result = evaluate_map(_map(est, est_colours), truth, colours)
    # (14, 0) is 1.0 m from (15, 0): on the gate, matched; (30, 0) is false.
    assert result["landmarks"] == 5
    assert result["true_cones"] == 4
    assert result["matched"] == 4
    assert result["false_landmarks"] == 1
    assert result["missed_cones"] == 0
    assert result["rmse_m"] == pytest.approx(math.sqrt((0.01 + 0.04 + 0.0 + 1.0) / 4))
    assert result["colour_accuracy"] == pytest.approx(0.5)


def test_hungarian_matching_is_global_not_greedy() -> None:
    # Greedy nearest would take est 0 -> truth 1 (0.4 m) and leave est 1 unmatched.
    truth = np.array([[0.0, 0.0], [1.0, 0.0]])
    est = np.array([[0.6, 0.0], [1.5, 0.0]])
    est_i, true_i, _ = match_cones(est, truth, gate_m=0.7)
    assert sorted(zip(est_i.tolist(), true_i.tolist(), strict=True)) == [(0, 0), (1, 1)]


def test_empty_map() -> None:
    result = evaluate_map(ConeMap.empty(), np.zeros((3, 2)))
    assert result["matched"] == 0 and result["missed_cones"] == 3
    assert math.isnan(result["rmse_m"])


def test_pose_errors_wraps_heading() -> None:
    truth = np.array([[0.0, 0.0, math.pi - 0.01], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]])
    est = np.array([[0.0, 0.0, -math.pi + 0.01], [1.0, 0.3, 0.0], [2.0, 0.4, 0.0]])
    result = pose_errors(est, truth)
    assert result["heading_rmse_rad"] == pytest.approx(math.sqrt(0.02 ** 2 / 3))
    assert result["pose_rmse_m"] == pytest.approx(math.sqrt((0.09 + 0.16) / 3))
    assert result["final_offset_m"] == pytest.approx(0.4)
    with pytest.raises(ValueError):
        pose_errors(est[:2], truth)


def test_nees_of_a_consistent_gaussian_sits_in_the_band() -> None:
    rng = np.random.default_rng(3)
    cov = np.array([[0.04, 0.01, 0.0], [0.01, 0.09, 0.0], [0.0, 0.0, 0.0004]])
    err = rng.multivariate_normal(np.zeros(3), cov, 4000)
    values = nees(err, np.tile(cov, (4000, 1, 1)))
    assert values.mean() == pytest.approx(3.0, rel=0.05)
    assert nees_fraction_in_band(values, 3) == pytest.approx(0.95, abs=0.015)
    lo, hi = nees_band(3)
    assert lo == pytest.approx(0.2158, abs=1e-3) and hi == pytest.approx(9.348, abs=1e-3)
    # An overconfident filter (covariance 4x too small) falls out of the band.
    assert nees_fraction_in_band(nees(err, np.tile(cov / 4, (4000, 1, 1))), 3) < 0.8
