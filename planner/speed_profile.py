"""Speed profiles: friction-circle forward-backward pass, and seed 002's two-level speed.

The forward-backward pass follows the idea of TUM's ``trajectory_planning_helpers``
``calc_vel_profile``: the curvature limits the speed through the lateral acceleration
(v^2 |kappa| <= a_lat); a forward pass limits the acceleration to what the friction circle leaves
after cornering, a backward pass the braking likewise. On a closed frame both passes start at
the slowest point of the curvature limit, where the speed of the lap is known.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from common.car import CarConfig

if TYPE_CHECKING:
    from planner.baseframe import SplineBaseframe

FloatArray = NDArray[np.float64]


@dataclass(frozen=True, slots=True)
class SpeedLimits:
    """A point mass's limits: lateral, drive and brake acceleration (m/s^2), top speed (m/s)."""

    lateral_mps2: float
    drive_mps2: float
    brake_mps2: float
    top_speed_mps: float

    @classmethod
    def from_car(
        cls, car: CarConfig, safety_factor: float = 1.0, max_speed_mps: float = math.inf,
        lateral_factor: float | None = None,
    ) -> SpeedLimits:
        """The car's limits scaled by ``safety_factor`` (0..1; the lateral one by
        ``lateral_factor`` when given), top speed capped."""
        lateral = safety_factor if lateral_factor is None else lateral_factor
        return cls(
            lateral_mps2=car.max_lateral_accel_mps2 * lateral,
            drive_mps2=car.max_drive_accel_mps2 * safety_factor,
            brake_mps2=car.max_brake_decel_mps2 * safety_factor,
            top_speed_mps=min(car.top_speed_mps, max_speed_mps),
        )


def steering_angle_speed_limit_mps(
    kappa_1pm: ArrayLike,
    wheelbase_m: float,
    max_steer_rad: float,
    understeer_rad_per_mps2: float,
    floor_mps: float,
) -> FloatArray:
    """Highest speed (M,) (m/s) at which the steering lock can hold the curvature (1/m): the
    steering needed is atan(L |kappa|) + K v^2 |kappa|, within ``max_steer_rad``. A bend
    tighter than the lock holds at any speed gets ``floor_mps`` (the car creeps round it on
    its feedback)."""
    k = np.abs(np.asarray(kappa_1pm, np.float64))
    spare = max_steer_rad - np.arctan(wheelbase_m * k)
    with np.errstate(divide="ignore", invalid="ignore"):
        v = np.sqrt(np.maximum(spare, 0.0) / np.maximum(understeer_rad_per_mps2 * k, 1e-12))
    return np.where(spare > 0.0, np.maximum(v, floor_mps), floor_mps)


def steering_lock_cap(
    car: CarConfig, lock_fraction: float, understeer_rad_per_mps2: float, floor_mps: float
) -> Callable[[FloatArray], FloatArray]:
    """:func:`steering_angle_speed_limit_mps` for ``car`` with ``lock_fraction`` of its lock
    (the rest corrects the car), as a function of the curvature (1/m)."""
    return functools.partial(steering_angle_speed_limit_mps, wheelbase_m=car.wheelbase_m,
                             max_steer_rad=lock_fraction * car.max_steer_rad,
                             understeer_rad_per_mps2=understeer_rad_per_mps2,
                             floor_mps=floor_mps)


def curvature_speed_limit_mps(kappa_1pm: ArrayLike, limits: SpeedLimits) -> FloatArray:
    """Highest speed (m/s) at each curvature (1/m): sqrt(a_lat / |kappa|), capped at top speed."""
    k = np.abs(np.asarray(kappa_1pm, np.float64))
    with np.errstate(divide="ignore"):
        v = np.sqrt(limits.lateral_mps2 / np.maximum(k, 1e-12))
    return np.minimum(v, limits.top_speed_mps)


def steering_rate_speed_limit_mps(
    kappa_1pm: ArrayLike,
    ds_m: float,
    wheelbase_m: float,
    max_steer_rate_radps: float,
    understeer_rad_per_mps2: float = 0.0,
    closed: bool = True,
) -> FloatArray:
    """Highest speed (M,) (m/s) at which the steering can follow the curvature's change along a
    path sampled every ``ds_m``: the steering needed is about L kappa + K v^2 kappa, so it turns
    at v |dkappa/ds| (L + K v^2), which must stay within ``max_steer_rate_radps``."""
    k = np.asarray(kappa_1pm, np.float64)
    if len(k) < 3:
        return np.full(len(k), np.inf)
    mode = "wrap" if closed else "nearest"
    from scipy.ndimage import uniform_filter1d  # local: only the profile needs it

    dk = np.abs(np.gradient(uniform_filter1d(k, 5, mode=mode), ds_m))
    if closed:
        dk[0] = abs(float(k[1] - k[-1])) / (2.0 * ds_m)
        dk[-1] = abs(float(k[0] - k[-2])) / (2.0 * ds_m)
    # v |dk| (L + K v^2) grows with v: where it meets the rate R is the one real root of
    # K dk v^3 + L dk v - R (closed form, was 40 bisections), at most 1000 m/s
    rate = max_steer_rate_radps
    with np.errstate(divide="ignore", over="ignore", invalid="ignore"):
        linear = rate / (dk * wheelbase_m)  # K = 0
        if understeer_rad_per_mps2 > 0.0:
            p = wheelbase_m / understeer_rad_per_mps2  # v^3 + p v + q = 0, q = -R / (K dk)
            q_abs = rate / (understeer_rad_per_mps2 * dk)
            root = 2.0 * math.sqrt(p / 3.0) * np.sinh(
                np.arcsinh(1.5 * q_abs / p * math.sqrt(3.0 / p)) / 3.0)
            v = np.where(np.isfinite(root), root, linear)
        else:
            v = linear
    return np.asarray(np.minimum(np.where(dk > 0.0, v, np.inf), 1e3), np.float64)


def _pass(v_lim: FloatArray, kappa: FloatArray, ds: FloatArray, a_lon: float, a_lat: float,
          v0: float) -> FloatArray:
    """One pass: v[i+1] <= sqrt(v[i]^2 + 2 a ds[i]), with a the longitudinal acceleration the
    friction circle leaves at v[i] on curvature kappa[i]. The loop runs on Python floats, not
    numpy scalars: it runs for the planner's every profile."""
    limits, curv, steps = v_lim.tolist(), kappa.tolist(), ds.tolist()
    v = min(float(v0), limits[0])
    out = [v]
    sqrt = math.sqrt
    for i in range(len(limits) - 1):
        usage = v * v * abs(curv[i]) / a_lat
        a = 0.0 if usage >= 1.0 else a_lon * sqrt(1.0 - usage * usage)
        v = min(limits[i + 1], sqrt(v * v + 2.0 * a * steps[i]))
        out.append(v)
    return np.asarray(out, np.float64)


def forward_backward_speed_mps(
    kappa_1pm: ArrayLike,
    ds_m: ArrayLike,
    limits: SpeedLimits,
    closed: bool,
    v_start_mps: float | None = None,
    v_end_mps: float | None = None,
    v_limit_mps: ArrayLike | None = None,
) -> FloatArray:
    """The friction-limited speed (M,) (m/s) at M samples of curvature ``kappa_1pm``.

    ``v_limit_mps`` (M,) is an optional further upper bound (e.g. seed 002's two speed levels).
    ``ds_m`` is the distance from sample i to sample i+1: (M,) for a closed frame (the last one
    back to sample 0), (M-1,) for an open one. An open frame starts at ``v_start_mps`` (default
    the limit) and ends at ``v_end_mps`` (default the limit).
    """
    kappa = np.asarray(kappa_1pm, np.float64)
    ds = np.asarray(ds_m, np.float64)
    m = len(kappa)
    if m == 0:
        return np.zeros(0)
    if len(ds) != (m if closed else m - 1):
        raise ValueError(f"ds_m has {len(ds)} entries for {m} samples (closed={closed})")
    v_lim = curvature_speed_limit_mps(kappa, limits)
    if v_limit_mps is not None:
        v_lim = np.minimum(v_lim, np.asarray(v_limit_mps, np.float64))
    if closed:
        i0 = int(np.argmin(v_lim))
        order = np.r_[np.arange(i0, m), np.arange(0, i0), i0]
        k = kappa[order]
        vl = v_lim[order]
        d = np.r_[ds[i0:], ds[:i0]]
        fwd = _pass(vl, k, d, limits.drive_mps2, limits.lateral_mps2, vl[0])
        bwd = _pass(vl[::-1], k[::-1], d[::-1], limits.brake_mps2, limits.lateral_mps2,
                    vl[-1])[::-1]
        v_rolled = np.minimum(fwd, bwd)[:-1]
        v = np.empty(m)
        v[order[:-1]] = v_rolled
        return v
    v0 = v_lim[0] if v_start_mps is None else v_start_mps
    v1 = v_lim[-1] if v_end_mps is None else v_end_mps
    fwd = _pass(v_lim, kappa, ds, limits.drive_mps2, limits.lateral_mps2, v0)
    bwd = _pass(v_lim[::-1], kappa[::-1], ds[::-1], limits.brake_mps2, limits.lateral_mps2, v1)
    return np.asarray(np.minimum(fwd, bwd[::-1]), np.float64)


def two_level_speed_mps(
    s_m: ArrayLike,
    heading_rad: ArrayLike,
    closed: bool,
    length_m: float,
    fast_mps: float,
    slow_mps: float,
    turn_rad: float,
    preview_m: float,
) -> FloatArray:
    """Seed 002's speed: ``slow`` where the frame turns by more than ``turn_rad`` over the next
    ``preview_m``, else ``fast`` (M,) (m/s)."""
    s = np.asarray(s_m, np.float64)
    h = np.unwrap(np.asarray(heading_rad, np.float64))
    if closed:
        total_turn = h[-1] - h[0] + _wrap(h[0] - h[-1])
        s_ext = np.r_[s, s + length_m]
        h_ext = np.r_[h, h + total_turn]
    else:
        s_ext, h_ext = s, h
    ahead = np.interp(np.minimum(s + preview_m, s_ext[-1]), s_ext, h_ext)
    turn = np.abs(ahead - h)
    return np.where(turn > turn_rad, slow_mps, fast_mps).astype(np.float64)


def _wrap(a: float) -> float:
    return float((a + math.pi) % (2.0 * math.pi) - math.pi)


def lap_time_s(speed_mps: ArrayLike, ds_m: ArrayLike, closed: bool = True) -> float:
    """Time (s) to drive the samples at ``speed_mps`` with constant acceleration between them."""
    v = np.asarray(speed_mps, np.float64)
    ds = np.asarray(ds_m, np.float64)
    v_next = np.r_[v[1:], v[:1]] if closed else v[1:]
    mean = np.maximum(0.5 * (v[: len(ds)] + v_next[: len(ds)]), 1e-6)
    return float(np.sum(ds / mean))


def _reference_frame(path_xy: ArrayLike, closed: bool) -> SplineBaseframe:
    """The baseframe the friction-limited references are timed on: the path as a spline,
    resampled every 1 m and lightly smoothed as the planner does, sampled every 0.5 m."""
    from planner.baseframe import SplineBaseframe  # local: baseframe imports nothing from here

    return SplineBaseframe(path_xy, closed=closed, resample_m=1.0, smoothing_m=1.0, step_m=0.5)


def min_lap_time_s(centreline_xy: ArrayLike, car: CarConfig,
                   max_speed_mps: float = math.inf) -> float:
    """Friction-limited minimum lap time (s) along a closed centreline (N, 2) (m).

    A point mass with the car's lateral, drive and brake limits and top speed (no safety factor)
    on the centreline's baseframe (a periodic spline, resampled every 1 m and lightly smoothed as
    the planner does), on a flying lap; ``max_speed_mps`` (m/s) caps the top speed further.
    """
    frame = _reference_frame(centreline_xy, closed=True)
    limits = SpeedLimits.from_car(car, max_speed_mps=max_speed_mps)
    ds = np.full(len(frame.s_m), frame.step_m)
    v = forward_backward_speed_mps(frame.curvature_1pm, ds, limits, closed=True)
    return lap_time_s(v, ds, closed=True)


def min_standing_lap_time_s(centreline_xy: ArrayLike, car: CarConfig) -> float:
    """Friction-limited minimum time (s) of one lap along a closed centreline (N, 2) (m) from a
    standstill at its first point: the same point mass and baseframe as :func:`min_lap_time_s`,
    starting at rest and free to cross the line at speed (the explored lap of an autonomous
    run is timed from the go, a standing start; its flying-lap minimum leaves the launch out).
    """
    frame = _reference_frame(centreline_xy, closed=True)
    limits = SpeedLimits.from_car(car)
    kappa = np.r_[frame.curvature_1pm, frame.curvature_1pm[:1]]  # the line again at the end
    ds = np.full(len(kappa) - 1, frame.step_m)
    v = forward_backward_speed_mps(kappa, ds, limits, closed=False, v_start_mps=0.0)
    return lap_time_s(v, ds, closed=False)


def min_run_time_s(path_xy: ArrayLike, car: CarConfig, s_from_m: float, s_to_m: float) -> float:
    """Friction-limited minimum time (s) from arc length ``s_from_m`` to ``s_to_m`` (m) along an
    open path (N, 2) (m) on which a point mass starts at standstill at the first point.

    The same point mass as :func:`min_lap_time_s` (the car's lateral, drive and brake limits and
    top speed, no safety factor; the path's baseframe resampled every 1 m and lightly smoothed),
    free to leave the path's end at speed: the friction limit of an acceleration run.
    """
    frame = _reference_frame(path_xy, closed=False)
    limits = SpeedLimits.from_car(car)
    ds = np.full(len(frame.s_m) - 1, frame.step_m)
    v = forward_backward_speed_mps(frame.curvature_1pm, ds, limits, closed=False,
                                   v_start_mps=0.0)
    mean = np.maximum(0.5 * (v[1:] + v[:-1]), 1e-6)
    t = np.concatenate([[0.0], np.cumsum(ds / mean)])
    return float(np.interp(s_to_m, frame.s_m, t) - np.interp(s_from_m, frame.s_m, t))


def late_cover_table(stop_distance_m: Callable[[float], float] | None, late_s: float
                     ) -> tuple[FloatArray, FloatArray]:
    """(room (m), speed (m/s)), both increasing: the highest speed from which the car, driving
    on for ``late_s`` and then stopping (``stop_distance_m``), stays within the room; empty
    arrays without a ``stop_distance_m``."""
    if stop_distance_m is None:
        return np.zeros(0), np.zeros(0)
    speed = np.arange(0.0, 60.0, 0.05)
    room = np.array([v * late_s + stop_distance_m(float(v)) for v in speed])
    return room, speed
