"""Steering laws: seed 002's P on the heading error to a look-ahead point, pure pursuit, Stanley.

Each law is a tiny class with ``reset()`` and ``update(x, y, yaw, speed, path) -> steering (rad)``;
the pose is the rear axle (the vehicle origin) in the world frame; ``path`` a :class:`PathRef`.
"""

from __future__ import annotations

import math
from bisect import bisect_right
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from common.messages import TargetStates

FloatArray = NDArray[np.float64]


def _interp(x: float, xp: list[float], fp: list[float]) -> float:
    """``float(np.interp(x, xp, fp))`` for a scalar ``x`` on Python floats: the same steps
    (the segment with xp[j] <= x < xp[j + 1], its slope, held beyond the ends), the same bits,
    without numpy's per-call overhead. ``xp`` non-decreasing, not empty."""
    if x != x:  # NaN
        return x
    if x < xp[0]:
        return fp[0]
    if x > xp[-1]:
        return fp[-1]
    j = bisect_right(xp, x) - 1
    if j == len(xp) - 1 or xp[j] == x:
        return fp[j]
    slope = (fp[j + 1] - fp[j]) / (xp[j + 1] - xp[j])
    y = slope * (x - xp[j]) + fp[j]
    if y != y:  # as numpy: from the other end, else the held value of a flat segment
        y = slope * (x - xp[j + 1]) + fp[j + 1]
        if y != y and fp[j] == fp[j + 1]:
            y = fp[j]
    return y


@dataclass(frozen=True, slots=True)
class PathRef:
    """A path to follow: positions, headings, curvatures, speeds (K,) and arc length (K,)."""

    x_m: FloatArray
    y_m: FloatArray
    yaw_rad: FloatArray
    curvature_1pm: FloatArray
    speed_mps: FloatArray
    s_m: FloatArray
    # the same samples as Python floats (a control tick reads a few of them: numpy's per-call
    # overhead would dominate), the heading unwrapped once per path
    _x: list[float] = field(init=False, repr=False, compare=False)
    _y: list[float] = field(init=False, repr=False, compare=False)
    _s: list[float] = field(init=False, repr=False, compare=False)
    _yaw_unwrapped: list[float] = field(init=False, repr=False, compare=False)
    _kappa: list[float] = field(init=False, repr=False, compare=False)
    _speed: list[float] = field(init=False, repr=False, compare=False)
    _last_nearest: list[tuple[float, float, tuple[float, float]]] = field(
        init=False, repr=False, compare=False)
    """The last :meth:`nearest` query and answer (a tick asks twice: steering and speed)."""

    def __post_init__(self) -> None:
        def floats(values: FloatArray) -> list[float]:
            return [float(v) for v in np.asarray(values, np.float64).ravel()]

        object.__setattr__(self, "_x", floats(self.x_m))
        object.__setattr__(self, "_y", floats(self.y_m))
        object.__setattr__(self, "_s", floats(self.s_m))
        object.__setattr__(self, "_yaw_unwrapped", floats(np.unwrap(self.yaw_rad)))
        object.__setattr__(self, "_kappa", floats(self.curvature_1pm))
        object.__setattr__(self, "_speed", floats(self.speed_mps))
        object.__setattr__(self, "_last_nearest", [])

    @classmethod
    def from_targets(cls, targets: TargetStates) -> PathRef:
        """The target states of a plan as a path."""
        x = np.asarray(targets.x_m, np.float64)
        y = np.asarray(targets.y_m, np.float64)
        seg = np.hypot(np.diff(x), np.diff(y))
        s = np.concatenate([[0.0], np.cumsum(seg)])
        return cls(x, y, np.asarray(targets.yaw_rad, np.float64),
                   np.asarray(targets.curvature_1pm, np.float64),
                   np.asarray(targets.speed_mps, np.float64), s)

    def __len__(self) -> int:
        return int(self.x_m.shape[0])

    def nearest(self, x_m: float, y_m: float) -> tuple[float, float]:
        """Arc length (m) of the point of the path nearest (x, y), and the signed cross-track
        error (m): positive when the path lies to the left of the point (the point is right of
        the path, so steering left corrects it)."""
        memo = self._last_nearest
        if memo and memo[0][0] is x_m and memo[0][1] is y_m:  # the very same floats again
            return memo[0][2]
        answer = self._nearest(x_m, y_m)
        memo[:] = [(x_m, y_m, answer)]
        return answer

    def _nearest(self, x_m: float, y_m: float) -> tuple[float, float]:
        dx = self.x_m - x_m
        dy = self.y_m - y_m
        i = int(np.argmin(dx * dx + dy * dy))
        xs, ys, ss = self._x, self._y, self._s
        best_s, best_d2, best_e = ss[i], math.inf, 0.0
        for a in (i - 1, i):
            b = a + 1
            if a < 0 or b >= len(xs):
                continue
            vx, vy = xs[b] - xs[a], ys[b] - ys[a]
            seg2 = vx * vx + vy * vy
            if seg2 <= 0.0:
                continue
            t = ((x_m - xs[a]) * vx + (y_m - ys[a]) * vy) / seg2
            t = min(max(t, 0.0), 1.0)
            px, py = xs[a] + t * vx, ys[a] + t * vy
            d2 = (x_m - px) ** 2 + (y_m - py) ** 2
            if d2 < best_d2:
                # positive: the path is to the left of the direction of travel from the point
                side = vx * (y_m - ys[a]) - vy * (x_m - xs[a])
                best_s = ss[a] + t * math.sqrt(seg2)
                best_d2 = d2
                best_e = -math.copysign(math.sqrt(d2), side)
        if not math.isfinite(best_d2):
            best_e = 0.0
        return best_s, best_e

    def at(self, s_m: float) -> tuple[float, float, float, float]:
        """Position, heading and curvature at arc length ``s_m``; beyond the end the path goes
        straight on along its last heading."""
        ss = self._s
        end = ss[-1]
        if s_m <= end or len(ss) < 2:
            x = _interp(s_m, ss, self._x)
            y = _interp(s_m, ss, self._y)
            yaw = _interp(s_m, ss, self._yaw_unwrapped)
            k = _interp(s_m, ss, self._kappa)
            return x, y, math.remainder(yaw, 2.0 * math.pi), k
        yaw = float(self.yaw_rad[-1])
        extra = s_m - end
        return (self._x[-1] + extra * math.cos(yaw),
                self._y[-1] + extra * math.sin(yaw), yaw, 0.0)

    def speed_at(self, s_m: float) -> float:
        """Target speed (m/s) at arc length ``s_m`` (held beyond the ends)."""
        return _interp(s_m, self._s, self._speed)


class SteeringLaw:
    """Base of the steering laws."""

    def reset(self) -> None:
        """Forget any state."""

    def update(self, x_m: float, y_m: float, yaw_rad: float, speed_mps: float,
               path: PathRef) -> float:
        """Road-wheel steering angle (rad), positive left."""
        raise NotImplementedError


class Lookahead:
    """Look-ahead distance (m): base + speed x time, clipped."""

    def __init__(self, base_m: float, time_s: float, min_m: float, max_m: float) -> None:
        self.base_m, self.time_s, self.min_m, self.max_m = base_m, time_s, min_m, max_m

    def __call__(self, speed_mps: float) -> float:
        return min(max(self.base_m + abs(speed_mps) * self.time_s, self.min_m), self.max_m)


def _target_point(x_m: float, y_m: float, path: PathRef, distance_m: float
                  ) -> tuple[float, float]:
    s_near, _ = path.nearest(x_m, y_m)
    tx, ty, _, _ = path.at(s_near + distance_m)
    return tx, ty


class HeadingP(SteeringLaw):
    """Seed 002: steering = kp x (bearing of the look-ahead point - yaw)."""

    def __init__(self, kp: float, lookahead: Lookahead) -> None:
        self.kp = kp
        self.lookahead = lookahead

    def update(self, x_m: float, y_m: float, yaw_rad: float, speed_mps: float,
               path: PathRef) -> float:
        tx, ty = _target_point(x_m, y_m, path, self.lookahead(speed_mps))
        error = math.remainder(math.atan2(ty - y_m, tx - x_m) - yaw_rad, 2.0 * math.pi)
        return self.kp * error


class PurePursuit(SteeringLaw):
    """Pure pursuit from the rear axle: delta = atan(2 L sin(alpha) / l_d)."""

    def __init__(self, wheelbase_m: float, lookahead: Lookahead) -> None:
        self.wheelbase_m = wheelbase_m
        self.lookahead = lookahead

    def update(self, x_m: float, y_m: float, yaw_rad: float, speed_mps: float,
               path: PathRef) -> float:
        tx, ty = _target_point(x_m, y_m, path, self.lookahead(speed_mps))
        dx, dy = tx - x_m, ty - y_m
        ld = max(math.hypot(dx, dy), 1e-3)
        alpha = math.remainder(math.atan2(dy, dx) - yaw_rad, 2.0 * math.pi)
        return math.atan2(2.0 * self.wheelbase_m * math.sin(alpha), ld)


class Stanley(SteeringLaw):
    """Stanley from the front axle: delta = heading error + atan(k e / (v + v_soft))."""

    def __init__(self, wheelbase_m: float, k: float, soft_mps: float) -> None:
        self.wheelbase_m = wheelbase_m
        self.k = k
        self.soft_mps = soft_mps

    def update(self, x_m: float, y_m: float, yaw_rad: float, speed_mps: float,
               path: PathRef) -> float:
        fx = x_m + self.wheelbase_m * math.cos(yaw_rad)
        fy = y_m + self.wheelbase_m * math.sin(yaw_rad)
        s, error = path.nearest(fx, fy)
        _, _, path_yaw, kappa = path.at(s)
        heading_error = math.remainder(path_yaw - yaw_rad, 2.0 * math.pi)
        # curvature feedforward keeps the front axle on a curve
        return (heading_error + math.atan2(self.k * error, abs(speed_mps) + self.soft_mps)
                + math.atan(self.wheelbase_m * kappa))


class CurvaturePreview(SteeringLaw):
    """Curvature feedforward with a preview, plus feedback on the lateral and heading errors:

        delta = atan(L kappa(s + v t_p)) + k_e e + k_psi e_psi

    with e the rear axle's distance to the path (positive when the path is to the left) and
    e_psi the path's heading less the car's. On the kinematic bicycle the errors then obey
    e'' + (v k_psi / L) e' + (v^2 k_e / L) e = 0; the gains are scheduled so that the error
    settles over the look-ahead distance l (natural frequency v / l, damping ``damping``):
    k_e = L / l^2, k_psi = 2 damping L / l. Unlike pure pursuit it does not cut corners: the
    feedforward steers the path's own curvature, the feedback only the error.
    """

    def __init__(self, wheelbase_m: float, lookahead: Lookahead, preview_s: float = 0.1,
                 damping: float = 0.9) -> None:
        self.wheelbase_m = wheelbase_m
        self.lookahead = lookahead
        self.preview_s = preview_s
        self.damping = damping

    def update(self, x_m: float, y_m: float, yaw_rad: float, speed_mps: float,
               path: PathRef) -> float:
        s, error = path.nearest(x_m, y_m)
        _, _, path_yaw, _ = path.at(s)
        _, _, _, kappa = path.at(s + max(speed_mps, 0.0) * self.preview_s)
        heading_error = math.remainder(path_yaw - yaw_rad, 2.0 * math.pi)
        ld = self.lookahead(speed_mps)
        k_e = self.wheelbase_m / (ld * ld)
        k_psi = 2.0 * self.damping * self.wheelbase_m / ld
        return math.atan(self.wheelbase_m * kappa) + k_e * error + k_psi * heading_error
