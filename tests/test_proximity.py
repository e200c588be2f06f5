"""common/proximity.py against scipy's KD-tree on random point sets."""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from common.proximity import near_any, pairs_within


def test_the_pairs_are_the_kd_trees_pairs() -> None:
    rng = np.random.default_rng(3)
    for n, m, radius in ((1, 1, 0.5), (7, 200, 1.0), (60, 40, 4.0), (30, 300, 0.3)):
        a = rng.uniform(-20.0, 20.0, (n, 2))
        b = rng.uniform(-20.0, 20.0, (m, 2))
        i, j = pairs_within(a, b, radius)
        expected = sorted((p, q) for p, qs in enumerate(cKDTree(b).query_ball_point(a, radius))
                          for q in qs)
        assert sorted(zip(i.tolist(), j.tolist(), strict=True)) == expected
        assert np.array_equal(near_any(a, b, radius),
                              np.array([len(q) > 0 for q in
                                        cKDTree(b).query_ball_point(a, radius)], bool))


def test_empty_sets_have_no_pairs() -> None:
    none = np.zeros((0, 2))
    some = np.ones((3, 2))
    assert len(pairs_within(none, some, 1.0)[0]) == 0
    assert len(pairs_within(some, none, 1.0)[1]) == 0
    assert near_any(some, none, 1.0).tolist() == [False] * 3
    assert near_any(some, [[1.0, 1.5]], 0.5).tolist() == [True] * 3
