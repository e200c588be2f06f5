"""Evaluation of a map and a pose track against ground truth, and filter consistency (NEES).

Used by every run's summary when ground truth exists (simulation) and by the mapper tests.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import linear_sum_assignment

from common.conventions import wrap_angles
from common.messages import ConeMap
from mapper.chi2 import chi2_ppf

FloatArray = NDArray[np.float64]
MATCH_GATE_M = 1.0
"""A landmark and a true cone further apart than this are never matched."""


def match_cones(est_xy_m: ArrayLike, true_xy_m: ArrayLike, gate_m: float = MATCH_GATE_M
                ) -> tuple[NDArray[np.int64], NDArray[np.int64], FloatArray]:
    """Hungarian assignment of estimated (N, 2) to true (M, 2) cones within ``gate_m``.

    Returns (estimate indices, true indices, distances (m)), one entry per matched pair.
    """
    est = np.asarray(est_xy_m, np.float64).reshape(-1, 2)
    true = np.asarray(true_xy_m, np.float64).reshape(-1, 2)
    if est.shape[0] == 0 or true.shape[0] == 0:
        empty = np.zeros(0, np.int64)
        return empty, empty, np.zeros(0)
    d = np.hypot(est[:, None, 0] - true[None, :, 0], est[:, None, 1] - true[None, :, 1])
    big = 1.0e9
    cost = np.where(d <= gate_m, d, big)
    rows, cols = linear_sum_assignment(cost)
    good = cost[rows, cols] < big
    return rows[good].astype(np.int64), cols[good].astype(np.int64), d[rows[good], cols[good]]


def evaluate_map(cones: ConeMap, true_xy: ArrayLike, true_colours: ArrayLike | None = None,
                 gate_m: float = MATCH_GATE_M) -> dict[str, Any]:
    """Compare a map with the true cones (N, 2) (and their colours (N,) ConeColour ints).

    Returns ``landmarks`` (map size), ``true_cones``, ``matched`` (Hungarian, ``gate_m``),
    ``false_landmarks`` (unmatched landmarks), ``missed_cones`` (unmatched true cones),
    ``rmse_m`` (position RMSE over matched pairs, NaN if none) and ``colour_accuracy`` (fraction
    of matched landmarks with the true colour; NaN without colours or matches).
    """
    true = np.asarray(true_xy, np.float64).reshape(-1, 2)
    est_i, true_i, dist = match_cones(cones.xy_m, true, gate_m)
    matched = int(est_i.size)
    result: dict[str, Any] = {
        "landmarks": len(cones),
        "true_cones": int(true.shape[0]),
        "matched": matched,
        "false_landmarks": len(cones) - matched,
        "missed_cones": int(true.shape[0]) - matched,
        "rmse_m": float(math.sqrt(np.mean(dist ** 2))) if matched else math.nan,
        "max_error_m": float(np.max(dist)) if matched else math.nan,
        "colour_accuracy": math.nan,
    }
    if true_colours is not None and matched:
        tc = np.asarray(true_colours, np.int64).reshape(-1)
        result["colour_accuracy"] = float(np.mean(cones.colour[est_i] == tc[true_i]))
    return result


def pose_errors(est: ArrayLike, truth: ArrayLike) -> dict[str, float]:
    """Pose track errors: ``est`` and ``truth`` (T, 3) rows of x_m, y_m, yaw_rad.

    Returns ``pose_rmse_m`` (position), ``heading_rmse_rad`` (wrapped), ``final_offset_m``
    (position error at the last row) and ``max_position_error_m``.
    """
    e = np.asarray(est, np.float64).reshape(-1, 3)
    t = np.asarray(truth, np.float64).reshape(-1, 3)
    if e.shape != t.shape:
        raise ValueError(f"pose_errors: shapes differ, {e.shape} vs {t.shape}")
    if e.shape[0] == 0:
        nan = math.nan
        return {"pose_rmse_m": nan, "heading_rmse_rad": nan, "final_offset_m": nan,
                "max_position_error_m": nan}
    dpos = np.hypot(e[:, 0] - t[:, 0], e[:, 1] - t[:, 1])
    dyaw = wrap_angles(e[:, 2] - t[:, 2])
    return {
        "pose_rmse_m": float(math.sqrt(np.mean(dpos ** 2))),
        "heading_rmse_rad": float(math.sqrt(np.mean(dyaw ** 2))),
        "final_offset_m": float(dpos[-1]),
        "max_position_error_m": float(np.max(dpos)),
    }


def pose_error_vectors(est: ArrayLike, truth: ArrayLike) -> FloatArray:
    """Errors (T, 3) of x, y and wrapped yaw between two (T, 3) pose tracks."""
    e = np.asarray(est, np.float64).reshape(-1, 3)
    t = np.asarray(truth, np.float64).reshape(-1, 3)
    err = e - t
    err[:, 2] = wrap_angles(err[:, 2])
    return err


def nees(err: ArrayLike, cov: ArrayLike) -> FloatArray:
    """Normalised estimation error squared per step: ``err`` (T, d), ``cov`` (T, d, d) -> (T,)."""
    e = np.asarray(err, np.float64)
    c = np.asarray(cov, np.float64)
    if e.ndim == 1:
        e, c = e[None, :], c[None, :, :]
    sol = np.linalg.solve(c, e[..., None])[..., 0]
    return np.einsum("ti,ti->t", e, sol)


def nees_band(dof: int, probability: float = 0.95) -> tuple[float, float]:
    """Two-sided chi-square band holding ``probability`` of a consistent filter's NEES."""
    tail = 0.5 * (1.0 - probability)
    return chi2_ppf(tail, dof), chi2_ppf(1.0 - tail, dof)


def nees_fraction_in_band(values: ArrayLike, dof: int, probability: float = 0.95) -> float:
    """Fraction of NEES values (T,) inside the two-sided ``probability`` chi-square band."""
    v = np.asarray(values, np.float64).reshape(-1)
    if v.size == 0:
        return math.nan
    lo, hi = nees_band(dof, probability)
    return float(np.mean((v >= lo) & (v <= hi)))
