"""The GNSS receiver's latency estimated from a drive's own sensors (no reference needed).

A fix stamped ``t`` (its UTC time on the receiving clock, or its receive time) was measured at
``t - L``. The filter's along-track position comes from the wheels, so a fix applied at ``t``
instead of ``t - L`` lies ``v L`` behind, which shows only when the speed changes: over a short
window ``[t_a, t_b]`` the chord between two fixes must equal the chord of the dead-reckoned
track (wheel speed along the gyro's heading) over ``[t_a - L, t_b - L]``, whose length differs
from the one over ``[t_a, t_b]`` by about ``(v_b - v_a) L``. :func:`estimate_gnss_latency` finds
the lag that best aligns the two, with the wheel speed scale fitted alongside (least squares,
closed form per lag), on a grid refined by a parabola; its uncertainty is the delete-one-block
jackknife over :data:`JACKKNIFE_BLOCKS` stretches of the drive (the chords of neighbouring
windows share their errors, so a formula on the residuals would be too optimistic).

Positions, not the receiver's speed: a u-blox's speed and course are filtered and lag its
position by another 50-70 ms (on comma2k19's RAV4: the Doppler speed against the wheels gives
0.135 s, the positions 0.06 s). What is estimated is the latency relative to the wheel
odometry, which is what the filter needs: the wheels' own CAN delay is in it.

Needs a drive whose speed changes (accelerating, braking): at a constant speed the latency is
not observable and nothing is returned. The antenna's lever arm is ignored (its speed in a
corner differs from the rear axle's by the yaw rate times the lever arm across the direction of
travel; over a 0.5 s window that changes the chord by far less than the latency does).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

log = logging.getLogger(__name__)

FloatArray = NDArray[np.float64]

WINDOW_S = 0.5
"""Time between the two fixes of a chord (s): short enough that a corner's chord and arc and
the gyro bias's heading error do not matter, long enough to span several fixes."""
MIN_SPEED_MPS = 2.0
"""Chords where the wheels say slower than this are left out (the GNSS position noise is then
larger than the travel)."""
MIN_PAIRS = 30
JACKKNIFE_BLOCKS = 10
MAX_SIGMA_S = 0.03
"""An estimate less sure than this (its jackknife sigma, s) is not given: the drive's speed
changes too little against the fixes' noise (a drive at a steady speed)."""
MIN_SPEED_CHANGE_MPS = 1.0
"""Below this spread of the windows' speed changes (RMS of ``v_b - v_a`` times the number of
windows' square root, m/s) the latency is not observable."""


@dataclass(frozen=True, slots=True)
class LatencyEstimate:
    """A latency estimate: ``latency_s`` with its 1-sigma ``sigma_s`` (s); ``pairs`` chords
    used, ``rms_m`` their residual at the estimate, ``speed_scale`` the wheel speed scale
    fitted with it (GNSS chord over odometry chord)."""

    latency_s: float
    sigma_s: float
    pairs: int
    rms_m: float
    speed_scale: float
    method: str = "gnss_chords_vs_wheel_odometry"

    def as_dict(self) -> dict[str, float | int | str]:
        return {"latency_s": round(self.latency_s, 4), "sigma_s": round(self.sigma_s, 4),
                "pairs": self.pairs, "rms_m": round(self.rms_m, 4),
                "speed_scale": round(self.speed_scale, 5), "method": self.method}


def dead_reckoning(t_s: FloatArray, speed_mps: FloatArray, yaw_rate_t_s: FloatArray | None = None,
                   yaw_rate_radps: FloatArray | None = None) -> FloatArray:
    """The dead-reckoned track (N,) as complex east + i north (m, an arbitrary frame) at the
    odometry times ``t_s`` (N,): speed (N,) along the heading integrated from the yaw rate
    (M,) at its own times (M,) (trapezoids; straight ahead without a yaw rate)."""
    t = np.asarray(t_s, np.float64)
    v = np.asarray(speed_mps, np.float64)
    heading = np.zeros_like(t)
    if yaw_rate_t_s is not None and yaw_rate_radps is not None and len(yaw_rate_t_s) > 1:
        tr = np.asarray(yaw_rate_t_s, np.float64)
        r = np.asarray(yaw_rate_radps, np.float64)
        psi = np.concatenate([[0.0], np.cumsum(0.5 * (r[1:] + r[:-1]) * np.diff(tr))])
        heading = np.interp(t, tr, psi)
    step = v * np.exp(1j * heading)
    return np.concatenate([[0.0 + 0.0j], np.cumsum(0.5 * (step[1:] + step[:-1]) * np.diff(t))])


def _chord_pairs(fix_t_s: FloatArray, window_s: float) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """Indices (a, b) of fixes about ``window_s`` apart (within 20 %)."""
    b = np.searchsorted(fix_t_s, fix_t_s + window_s)
    a = np.arange(len(fix_t_s))
    ok = b < len(fix_t_s)
    a, b = a[ok], b[ok]
    gap = fix_t_s[b] - fix_t_s[a]
    keep = np.abs(gap - window_s) <= 0.2 * window_s
    return a[keep], b[keep]


class _Chords:
    """The chords of a drive, ready to be compared at any lag."""

    def __init__(self, fix_t_s: FloatArray, fix_en_m: FloatArray, odo_t_s: FloatArray,
                 track: FloatArray, speed_mps: FloatArray, window_s: float,
                 min_speed_mps: float) -> None:
        a, b = _chord_pairs(fix_t_s, window_s)
        inside = (fix_t_s[a] - 0.5 > odo_t_s[0]) & (fix_t_s[b] + 0.5 < odo_t_s[-1])
        a, b = a[inside], b[inside]
        v_a = np.interp(fix_t_s[a], odo_t_s, speed_mps)
        v_b = np.interp(fix_t_s[b], odo_t_s, speed_mps)
        moving = (v_a > min_speed_mps) & (v_b > min_speed_mps)
        self.a, self.b = a[moving], b[moving]
        self.t_a, self.t_b = fix_t_s[self.a], fix_t_s[self.b]
        d = fix_en_m[self.b] - fix_en_m[self.a]
        self.gnss_m = np.hypot(d[:, 0], d[:, 1])
        self.dv_mps = (v_b - v_a)[moving]
        self.odo_t_s, self.track = odo_t_s, track

    def __len__(self) -> int:
        return len(self.gnss_m)

    def odometry(self, lag_s: float) -> FloatArray:
        """The dead-reckoned chords (m) over the windows moved ``lag_s`` earlier."""
        za = (np.interp(self.t_a - lag_s, self.odo_t_s, self.track.real)
              + 1j * np.interp(self.t_a - lag_s, self.odo_t_s, self.track.imag))
        zb = (np.interp(self.t_b - lag_s, self.odo_t_s, self.track.real)
              + 1j * np.interp(self.t_b - lag_s, self.odo_t_s, self.track.imag))
        return np.abs(zb - za)


def _cost(gnss_m: FloatArray, odo_m: FloatArray) -> tuple[float, float]:
    """Sum of squared residuals (m^2) of ``gnss = scale * odo`` and the fitted scale."""
    den = float(odo_m @ odo_m)
    scale = float(gnss_m @ odo_m) / den if den > 0.0 else 1.0
    r = gnss_m - scale * odo_m
    return float(r @ r), scale


def _best_lag(chords: _Chords, select: NDArray[np.bool_], lags_s: FloatArray,
              odo_by_lag: FloatArray) -> tuple[float, bool]:
    """The lag (s) minimising the cost over the chords ``select``ed, refined by a parabola
    through the best grid point and its neighbours; False when the minimum is at an end."""
    g = chords.gnss_m[select]
    costs = np.array([_cost(g, odo[select])[0] for odo in odo_by_lag])
    i = int(np.argmin(costs))
    if i == 0 or i == len(lags_s) - 1:
        return float(lags_s[i]), False
    c0, c1, c2 = costs[i - 1], costs[i], costs[i + 1]
    curvature = c0 - 2.0 * c1 + c2
    step = float(lags_s[1] - lags_s[0])
    shift = 0.5 * (c0 - c2) / curvature if curvature > 0.0 else 0.0
    return float(lags_s[i] + step * float(np.clip(shift, -1.0, 1.0))), True


def estimate_gnss_latency(fix_t_s: FloatArray, fix_en_m: FloatArray, odo_t_s: FloatArray,
                          speed_mps: FloatArray, yaw_rate_t_s: FloatArray | None = None,
                          yaw_rate_radps: FloatArray | None = None, *,
                          window_s: float = WINDOW_S, min_lag_s: float = -0.1,
                          max_lag_s: float = 0.5, lag_step_s: float = 0.002,
                          min_speed_mps: float = MIN_SPEED_MPS) -> LatencyEstimate | None:
    """The GNSS latency (see the module docstring) from fixes at ``fix_t_s`` (N,) (s, as the
    filter times them with no latency) at ``fix_en_m`` (N, 2) (east, north, m, any local
    frame), the wheel odometry's speed ``speed_mps`` (M,) at ``odo_t_s`` (M,), and the yaw
    rate (K,) (rad/s, counter-clockwise; optional, for curved drives) at ``yaw_rate_t_s``
    (K,). Searches lags in ``[min_lag_s, max_lag_s]`` (s). None when the drive cannot tell
    (too few moving chords, a speed that hardly changes, a minimum at the search's end, a
    sigma above :data:`MAX_SIGMA_S`)."""
    fix_t = np.asarray(fix_t_s, np.float64)
    fix_en = np.asarray(fix_en_m, np.float64).reshape(-1, 2)
    odo_t = np.asarray(odo_t_s, np.float64)
    speed = np.asarray(speed_mps, np.float64)
    good = np.isfinite(fix_t) & np.all(np.isfinite(fix_en), axis=1)
    order = np.argsort(fix_t[good], kind="stable")
    fix_t, fix_en = fix_t[good][order], fix_en[good][order]
    ok = np.isfinite(odo_t) & np.isfinite(speed)
    odo_t, speed = odo_t[ok], speed[ok]
    if len(fix_t) < MIN_PAIRS or len(odo_t) < 2:
        log.info("GNSS latency: %d fixes and %d odometry samples: too few", len(fix_t),
                 len(odo_t))
        return None
    track = dead_reckoning(odo_t, speed, yaw_rate_t_s, yaw_rate_radps)
    chords = _Chords(fix_t, fix_en, odo_t, track, speed, window_s, min_speed_mps)
    if len(chords) < MIN_PAIRS:
        log.info("GNSS latency: %d moving chords of %.1f s: too few", len(chords), window_s)
        return None
    excitation = float(np.sqrt(np.sum(chords.dv_mps**2)))
    if excitation < MIN_SPEED_CHANGE_MPS:
        log.info("GNSS latency: the speed hardly changes (%.2f m/s over %d chords): "
                 "not observable", excitation, len(chords))
        return None
    lags = np.arange(min_lag_s, max_lag_s + 0.5 * lag_step_s, lag_step_s)
    odo_by_lag = np.stack([chords.odometry(float(lag)) for lag in lags])
    everything = np.ones(len(chords), dtype=bool)
    latency, interior = _best_lag(chords, everything, lags, odo_by_lag)
    if not interior:
        log.warning("GNSS latency: the best lag %.3f s is at the end of the search "
                    "[%.3f, %.3f] s: not trusted", latency, min_lag_s, max_lag_s)
        return None
    blocks = np.array_split(np.arange(len(chords)), JACKKNIFE_BLOCKS)
    leave_out = []
    for block in blocks:
        select = everything.copy()
        select[block] = False
        leave_out.append(_best_lag(chords, select, lags, odo_by_lag)[0])
    jack = np.asarray(leave_out)
    n = len(jack)
    sigma = float(np.sqrt((n - 1) / n * np.sum((jack - jack.mean()) ** 2)))
    if sigma > MAX_SIGMA_S:
        log.info("GNSS latency: %.3f s but its jackknife sigma is %.3f s (> %.3f s): the "
                 "speed changes too little to tell", latency, sigma, MAX_SIGMA_S)
        return None
    sse, scale = _cost(chords.gnss_m, chords.odometry(latency))
    estimate = LatencyEstimate(latency_s=latency, sigma_s=max(sigma, 0.5 * lag_step_s),
                               pairs=len(chords), rms_m=float(np.sqrt(sse / len(chords))),
                               speed_scale=scale)
    log.info("GNSS latency %.3f +- %.3f s from %d chords of %.1f s (residual %.3f m RMS, "
             "wheel speed scale %.4f)", estimate.latency_s, estimate.sigma_s, estimate.pairs,
             window_s, estimate.rms_m, estimate.speed_scale)
    return estimate
