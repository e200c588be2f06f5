"""Solves with symmetric positive-definite matrices through LAPACK directly.

The UKF solves with its small covariances (10 x 10, innovations 1-40) on every IMU sample and
every update. ``scipy.linalg.solve``, ``cho_factor`` and ``cho_solve`` check and convert their
arguments in Python first, which costs 10-60 us per call, several times the solve itself; on
the car that time holds the executive process's interpreter lock (issue 19). These call the
same LAPACK routines (``?posv``, ``?potrf``, ``?potrs``) through ``scipy.linalg.lapack`` with
the same options, so their results are bit-identical to scipy's (and numpy's Cholesky factor:
tests/test_spd_solve.py).

Arguments must be finite float64 arrays (as scipy's with ``check_finite=False``); a matrix that
is not positive definite raises :class:`numpy.linalg.LinAlgError`, as scipy's do.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.linalg import lapack

FloatArray = NDArray[np.float64]


def solve_spd(a: FloatArray, b: FloatArray) -> FloatArray:
    """``a^-1 b`` for SPD ``a`` (n, n) and ``b`` (n, k): ``scipy.linalg.solve(a, b,
    assume_a="pos", check_finite=False)`` for n > 1 (scipy divides for a 1 x 1, which may
    round differently)."""
    if b.ndim != 2:
        raise ValueError(f"solve_spd: b must be (n, k), got {b.shape}")
    _, x, info = lapack.dposv(a, b, lower=0)
    _check(info, "solve_spd")
    return x  # type: ignore[no-any-return]


def cholesky_lower(s: FloatArray, clean: bool = False) -> FloatArray:
    """The lower Cholesky factor of SPD ``s`` (m, m), upper triangle left as it was:
    ``scipy.linalg.cho_factor(s, lower=True, check_finite=False)[0]``; ``clean``: the upper
    triangle zeroed, ``numpy.linalg.cholesky(s)``."""
    c, info = lapack.dpotrf(s, lower=1, clean=1 if clean else 0)
    _check(info, "cholesky_lower")
    return c  # type: ignore[no-any-return]


def cho_solve_lower(c: FloatArray, b: FloatArray) -> FloatArray:
    """``s^-1 b`` from :func:`cholesky_lower`'s ``c``, ``b`` (m,) or (m, k):
    ``scipy.linalg.cho_solve((c, True), b, check_finite=False)``."""
    x, info = lapack.dpotrs(c, b, lower=1)
    _check(info, "cho_solve_lower")
    return x  # type: ignore[no-any-return]


def _check(info: int, name: str) -> None:
    if info > 0:
        raise np.linalg.LinAlgError(f"{name}: matrix not positive definite (minor {info})")
    if info < 0:
        raise ValueError(f"{name}: illegal value in argument {-info}")
