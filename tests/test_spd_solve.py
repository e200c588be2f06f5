"""The UKF's direct LAPACK solves give scipy's results bit for bit, and numpy's to rounding.

numpy and scipy each bundle their own OpenBLAS (0.3.31 and 0.3.30 here), which picks its
kernels by the CPU: with the Haswell kernels (AVX2) the two factor a matrix bit for bit alike,
with the SkylakeX ones (AVX-512) they differ in the last bits."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg

from mapper.spd_solve import cho_solve_lower, cholesky_lower, solve_spd


def _spd(rng: np.random.Generator, n: int) -> np.ndarray:
    """A random SPD matrix with entries spanning the UKF's scales (1e-4 .. 10)."""
    a = rng.normal(size=(n, n)) * rng.uniform(1e-4, 10.0)
    p = a @ a.T + np.eye(n) * rng.uniform(1e-9, 1.0)
    return 0.5 * (p + p.T)


def test_results_are_bit_identical_to_scipy_and_numpy() -> None:
    rng = np.random.default_rng(19)
    for _ in range(300):
        n = int(rng.integers(1, 41))
        s = _spd(rng, n)
        b1 = rng.normal(size=n)
        b2 = rng.normal(size=(n, int(rng.integers(1, 12))))
        b2t = rng.normal(size=(b2.shape[1], n)).T  # a transposed view, as K = solve(S, M.T)
        cho = scipy.linalg.cho_factor(s, lower=True, check_finite=False)
        c = cholesky_lower(s)
        assert np.array_equal(c, cho[0])
        clean = cholesky_lower(s, clean=True)
        assert np.array_equal(np.tril(clean), clean)
        assert np.array_equal(np.tril(c), clean)
        # a Cholesky factor's rounding: n eps relative to the diagonal's square root
        scale = float(np.sqrt(np.max(np.diag(s))))
        np.testing.assert_allclose(clean, np.linalg.cholesky(s), rtol=0.0,
                                   atol=4.0 * n * np.finfo(float).eps * scale)
        for b in (b1, b2, b2t):
            assert np.array_equal(cho_solve_lower(c, b),
                                  scipy.linalg.cho_solve(cho, b, check_finite=False))
        for b in (b2, b2t) if n > 1 else ():  # scipy divides for a 1 x 1 (the UKF's are 6+)
            assert np.array_equal(solve_spd(s, b),
                                  scipy.linalg.solve(s, b, assume_a="pos", check_finite=False))


def test_a_matrix_not_positive_definite_raises_as_scipy_does() -> None:
    s = np.array([[1.0, 2.0], [2.0, 1.0]])
    with pytest.raises(np.linalg.LinAlgError):
        scipy.linalg.cho_factor(s, lower=True, check_finite=False)
    with pytest.raises(np.linalg.LinAlgError):
        cholesky_lower(s)
    with pytest.raises(np.linalg.LinAlgError):
        solve_spd(s, np.eye(2))


def test_solve_spd_takes_only_a_matrix_of_right_hand_sides() -> None:
    with pytest.raises(ValueError, match=r"\(n, k\)"):
        solve_spd(np.eye(3), np.ones(3))
