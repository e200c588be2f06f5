"""A localisation track against a reference track: position and course errors, NEES.

Everything in one local ENU frame (m), headings as ENU yaws (rad, CCW from east; the course is
the direction of travel). The estimate (T samples) is interpolated linearly to the reference's
times (R samples, those inside the estimate's span); courses through their unwrapped angle.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]


@dataclass(frozen=True, slots=True)
class Track:
    """A track: ``t_s`` (N,) increasing, ``en_m`` (N, 2) east and north, ``course_rad`` (N,),
    and optionally ``cov_m2`` (N, 2, 2), the position covariance."""

    t_s: FloatArray
    en_m: FloatArray
    course_rad: FloatArray
    cov_m2: FloatArray | None = None

    def at(self, t_s: FloatArray) -> Track:
        """The track interpolated at ``t_s`` (inside its span)."""
        en = np.stack([np.interp(t_s, self.t_s, self.en_m[:, i]) for i in range(2)], axis=1)
        course = np.interp(t_s, self.t_s, np.unwrap(self.course_rad))
        cov = None
        if self.cov_m2 is not None:
            flat = self.cov_m2.reshape(len(self.t_s), 4)
            cov = np.stack([np.interp(t_s, self.t_s, flat[:, i]) for i in range(4)],
                           axis=1).reshape(len(t_s), 2, 2)
        return Track(np.asarray(t_s, np.float64), en, course, cov)


def wrap_deg(a: FloatArray) -> FloatArray:
    """Angles (deg) wrapped to [-180, 180)."""
    return np.mod(a + 180.0, 360.0) - 180.0


def errors(estimate: Track, reference: Track) -> tuple[FloatArray, FloatArray, FloatArray]:
    """(times (R',), horizontal position errors (R', 2) m, course errors (R',) deg) of the
    estimate at the reference's times inside the estimate's span."""
    inside = (reference.t_s >= estimate.t_s[0]) & (reference.t_s <= estimate.t_s[-1])
    t = reference.t_s[inside]
    est = estimate.at(t)
    d = est.en_m - reference.en_m[inside]
    dc = wrap_deg(np.degrees(est.course_rad - reference.course_rad[inside]))
    return t, d, dc


def rms(values: FloatArray) -> float:
    """Root mean square of the rows' norms ((N,) or (N, k)); NaN when empty."""
    v = np.asarray(values, np.float64)
    if v.size == 0:
        return math.nan
    sq = v * v if v.ndim == 1 else np.sum(v * v, axis=1)
    return float(np.sqrt(np.mean(sq)))


def position_nees(estimate: Track, reference: Track) -> FloatArray:
    """Position NEES (R',) at the reference's times: e^T P^-1 e (2 degrees of freedom, mean 2
    for a consistent filter)."""
    assert estimate.cov_m2 is not None, "the estimate carries no covariance"
    inside = (reference.t_s >= estimate.t_s[0]) & (reference.t_s <= estimate.t_s[-1])
    est = estimate.at(reference.t_s[inside])
    assert est.cov_m2 is not None
    d = est.en_m - reference.en_m[inside]
    sol = np.linalg.solve(est.cov_m2, d[:, :, None])[:, :, 0]
    return np.asarray(np.sum(d * sol, axis=1), np.float64)
