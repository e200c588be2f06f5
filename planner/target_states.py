"""A chosen manoeuvre as the timed target states the controller follows (the Plan's
``manoeuvre``): each point's speed within the profile, the friction circle on the manoeuvre's
own curvature and the brakes, and the time it is reached at."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from common.messages import TargetStates
from planner.manoeuvres import Candidate
from planner.speed_profile import SpeedLimits, curvature_speed_limit_mps

FloatArray = NDArray[np.float64]


def empty_targets() -> TargetStates:
    """A manoeuvre with no states."""
    z = np.zeros(0)
    return TargetStates(z, z, z, z, z, z)


def timed_targets(cand: Candidate, speed_at: Callable[[FloatArray], FloatArray],
                  limits: SpeedLimits, now_s: float, stop: bool,
                  min_plan_speed_mps: float, cap_mps: float = math.inf) -> TargetStates:
    """The candidate ``cand`` as target states timed from ``now_s`` (s): its speed (m/s) the
    least of the baseframe's profile at its arc lengths (``speed_at``), the friction circle
    on its own curvature (``limits``), its own cap and ``cap_mps`` (a fallback's hold);
    braked (within ``limits``) to stand at its end when ``stop``, or before the point where it
    comes too near a cone (its ``free_m``) if that is nearer; a candidate taken for a conflict
    far ahead stands before that (its ``stand_before_m``); otherwise never below
    ``min_plan_speed_mps`` (or its slowest limit, when that is lower)."""
    s = cand.s_m
    ds = np.linalg.norm(np.diff(cand.xy_m, axis=0), axis=1)
    v_lim = np.minimum(speed_at(s), curvature_speed_limit_mps(cand.curvature_1pm, limits))
    v_lim = np.minimum(v_lim, min(cand.speed_cap_mps, cap_mps))
    if stop:  # no feasible path: stand before the first cone it would pass too near, not on it
        v_lim = np.where(s - s[0] >= cand.free_m, 0.0, v_lim)
    elif math.isfinite(cand.stand_before_m):  # a conflict far ahead: able to stand before it
        v_lim = np.where(s - s[0] >= cand.stand_before_m, 0.0, v_lim)
    # a stop: brake (within the limits) to stand at the end of the candidate
    v_end = 0.0 if stop else float(v_lim[-1])
    # backward pass: every target can be reached with the (safety-scaled) brakes
    v = v_lim.copy()
    v[-1] = min(v[-1], v_end)
    for i in range(len(v) - 2, -1, -1):
        v[i] = min(v[i], math.sqrt(v[i + 1] ** 2 + 2.0 * limits.brake_mps2 * ds[i]))
    v = np.maximum(v, 0.0)
    if not stop:
        v = np.maximum(v, min(min_plan_speed_mps, float(v_lim.min())))
    v_mean = np.maximum(0.5 * (v[1:] + v[:-1]), 0.5)
    t = now_s + np.concatenate([[0.0], np.cumsum(ds / v_mean)])
    return TargetStates(t_s=t, x_m=cand.xy_m[:, 0], y_m=cand.xy_m[:, 1],
                        yaw_rad=cand.heading_rad, speed_mps=v,
                        curvature_1pm=cand.curvature_1pm)
