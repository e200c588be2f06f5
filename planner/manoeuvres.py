"""The manoeuvre generator (seed 002, 3.2.2).

From the current pose, candidate paths run to end states offset across the baseframe over a
horizon: in the Frenet frame d(s) is a cubic that starts at the car's lateral offset and heading
and ends at the offset with zero slope; beyond the horizon the offset is held. Candidates that come
within half the car's width plus a margin of a cone, or that bend more than the car can steer, are
dropped; the rest are graded on curvature, clearance, offset and agreement with the last choice.
At speed a manoeuvre reaches beyond the horizon at least as far as a plan followed late must
leave room for a stop (:meth:`ManoeuvreGenerator.length_m`).
"""

from __future__ import annotations

import collections
import math
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from common.car import CarConfig
from planner.baseframe import SplineBaseframe
from planner.boundary_walls import leaves_through
from planner.config import PlannerConfig

FloatArray = NDArray[np.float64]


@dataclass(frozen=True, slots=True)
class Candidate:
    """One candidate path: Frenet s, d (K,), world xy (K, 2), heading (K,), curvature (K,)."""

    offset_m: float
    s_m: FloatArray
    d_m: FloatArray
    xy_m: FloatArray
    heading_rad: FloatArray
    curvature_1pm: FloatArray
    clearance_m: float
    """Smallest distance from a cone centre to the circles covering the car along the path (m;
    inf without cones)."""
    feasible: bool
    cost: float
    reason: str = ""
    collision_free: bool = True
    max_curvature_1pm: float = 0.0
    speed_cap_mps: float = math.inf
    """A fallback manoeuvre (short horizon, sharp) is driven no faster than this (m/s)."""
    leaves_lane: bool = False
    """It leaves the lane between two of its cones (:mod:`planner.boundary_walls`)."""
    free_m: float = math.inf
    """How far along it (m) a stop may stand: its last point before the circles covering the
    car come nearer a cone than the near margin (``cone_clearance_near_m``, or what the car has
    where it stands, if less), by more than the circles overstate the body's reach
    (``circle_overreach_m``); inf: clear all the way."""
    hit_m: float = math.inf
    """How far along it (m) it first comes nearer a cone than the hard margin; inf: never."""
    bent_m: float = math.inf
    """How far along it (m) it first bends beyond the steering's limit; inf: never."""
    cost_before_conflict: float = 0.0
    """Its cost with the room to the cones counted only before its first conflict (the
    nearer of ``hit_m`` and ``bent_m``): how a far conflict's candidates are graded."""
    stand_before_m: float = math.inf
    """Taken for a conflict far ahead (:meth:`ManoeuvreGenerator.generate`): the targets stand
    before this arc length (m) from its start; inf: driven to its end."""


def _path_geometry(xy: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Heading and curvature of polylines by finite differences: ``xy`` (..., K, 2), K >= 3,
    gives (..., K) each (every polyline on its own, as if alone). The ends take second-order
    one-sided differences: the first point is where the car stands, and a first-order
    difference reads its heading half a step along (on the lock's circle, 0.5 m steps, 0.09
    rad more turned than the car: at a rules-minimum hairpin's exit the car then ran wide)."""
    d1 = np.gradient(xy, axis=-2, edge_order=2)
    d2 = np.gradient(d1, axis=-2, edge_order=2)
    heading = np.arctan2(d1[..., 1], d1[..., 0])
    speed = np.maximum(np.linalg.norm(d1, axis=-1), 1e-9)
    kappa = (d1[..., 0] * d2[..., 1] - d1[..., 1] * d2[..., 0]) / speed**3
    return heading, kappa


class ManoeuvreGenerator:
    """Candidate manoeuvres along a baseframe, collision and curvature checked, graded."""

    def __init__(self, config: PlannerConfig, car: CarConfig,
                 stop_distance_m: Callable[[float], float] | None = None) -> None:
        """``stop_distance_m(speed_mps)``: the room (m) a late plan must leave for a stop from
        that speed (the safety supervisor's rule); None: manoeuvres end at the horizon plus
        ``extension_m``, whatever the speed."""
        self.config = config
        self.car = car
        self.stop_distance_m = stop_distance_m
        self.kappa_max_1pm = (
            math.tan(car.max_steer_rad) / car.wheelbase_m * config.curvature_limit_fraction
        )
        # circles covering the car body (corners included), centres ahead of the rear axle
        front = car.length_m - car.rear_overhang_m
        rear = -car.rear_overhang_m
        half_w = car.width_m / 2.0
        n = max(int(math.ceil(2.0 * (front - rear) / car.width_m)), 2)
        spacing = (front - rear) / n
        self.circle_offsets_m = rear + spacing * (np.arange(n) + 0.5)
        self.circle_radius_m = math.hypot(half_w, spacing / 2.0)
        self.circle_overreach_m = self.circle_radius_m - half_w
        """How far (m) the circles reach beyond the body's side, at most (between corners)."""
        self.required_m = self.circle_radius_m + config.cone_clearance_m
        self.rejections: collections.Counter[str] = collections.Counter()
        """Rejected candidates by family and check (``"nominal: clearance"``, ...)."""

    def offsets(self) -> FloatArray:
        """The end-state offsets (m), symmetric about the baseframe."""
        c = self.config
        return np.linspace(-c.offsets_max_m, c.offsets_max_m, max(c.offsets_count, 1))

    def horizon_m(self, speed_mps: float) -> float:
        """Horizon (m): speed x horizon time, clipped to [min, max]."""
        c = self.config
        return float(np.clip(abs(speed_mps) * c.horizon_time_s, c.horizon_min_m, c.horizon_max_m))

    def length_m(self, horizon_m: float, speed_mps: float) -> float:
        """A manoeuvre's length (m): the horizon plus ``extension_m``, or more at speed: as far
        as the car drives in ``late_cover_s`` plus the stop a late plan must leave room for."""
        c = self.config
        length = horizon_m + c.extension_m
        if self.stop_distance_m is not None:
            speed = abs(speed_mps)
            length = max(length, speed * c.late_cover_s + self.stop_distance_m(speed))
        return length

    def generate(
        self,
        frame: SplineBaseframe,
        s0_m: float,
        d0_m: float,
        yaw_rad: float,
        speed_mps: float,
        cones_xy_m: FloatArray,
        last_offset_m: float | None,
        start: tuple[float, float] | None = None,
        speed_margin: bool = False,
        walls: FloatArray | None = None,
        far_conflicts: bool = True,
    ) -> tuple[list[Candidate], int]:
        """Candidates from Frenet (s0, d0) with the car's yaw; the chosen one's index (-1 when
        none is feasible). ``cones_xy_m`` (N, 2) are the obstacles (world frame).
        ``speed_margin``: the full margin grows with the speed (:meth:`full_margin_m`; the
        planner asks it while exploring).

        ``start`` = (d, dd/ds) overrides the start state (offset (m) and slope) taken from the
        car. The search widens until a feasible candidate is found: the configured offsets over
        the speed's horizon, then more and wider offsets, then shorter horizons (a slower,
        sharper manoeuvre: those carry a speed cap), and last at a crawl with the cone's own
        radius as the margin throughout (at walking pace the car follows its path to a few
        centimetres: a rules-minimum hairpin leaves no more room than that to a car placed on
        its centreline). Each family's rejections are counted in :attr:`rejections`
        (``family: check``). ``walls`` (W, 2, 2): the lane's boundaries a candidate may not
        leave through (:mod:`planner.boundary_walls`; refused as ``boundary``).
        ``far_conflicts``: with no candidate clear all along, one whose only conflict lies
        beyond the car's commitment may be taken (:meth:`_far_conflict`; also
        ``far_conflict_stop``)."""
        tree = cKDTree(cones_xy_m) if len(cones_xy_m) else None
        far_conflicts = far_conflicts and self.config.far_conflict_stop
        cands: list[Candidate] = []
        for family, offsets, horizon, cap, margin in self._families(speed_mps, speed_margin):
            cands = self._family(frame, s0_m, d0_m, yaw_rad, speed_mps, tree, last_offset_m,
                                 start, offsets, horizon, cap, margin, walls)
            if not cands:
                return [], -1
            feasible = [i for i, cand in enumerate(cands) if cand.feasible]
            for cand in cands:
                if not cand.feasible:
                    self.rejections[f"{family}: {cand.reason.split(' ')[0]}"] += 1
            if feasible:
                return cands, min(feasible, key=lambda i: cands[i].cost)
            if family == "wide" and far_conflicts:
                far = self._far_conflict(cands, horizon, speed_mps)
                if far is not None:
                    return cands, far
            if family == "shortest":
                # none within the curvature limit: the least bent collision-free one (the car
                # is slow there and steers at its limit), so a track at the car's limit does
                # not stop it; only with none at all, the crawl
                clear = [i for i, cand in enumerate(cands) if cand.collision_free]
                if clear:
                    return cands, min(clear, key=lambda i: (cands[i].max_curvature_1pm,
                                                            cands[i].cost))
        clear = [i for i, cand in enumerate(cands) if cand.collision_free]
        if clear:
            return cands, min(clear, key=lambda i: (cands[i].max_curvature_1pm, cands[i].cost))
        return cands, -1

    def commit_m(self, horizon_m: float, speed_mps: float) -> float:
        """How far along a manoeuvre (m) the car is committed to it: its shaped part (the
        horizon), and what it drives in ``late_cover_s`` and then needs to stop from
        ``speed_mps`` (the supervisor's rule; without one, the brakes at the friction safety
        factor)."""
        c = self.config
        speed = abs(speed_mps)
        if self.stop_distance_m is not None:
            stop = self.stop_distance_m(speed)
        else:
            stop = speed**2 / (2.0 * self.car.max_brake_decel_mps2 * c.friction_safety_factor)
        return max(horizon_m, speed * c.late_cover_s + stop)

    def _far_conflict(self, cands: list[Candidate], horizon_m: float, speed_mps: float
                      ) -> int | None:
        """Among candidates refused only for a conflict beyond the car's commitment
        (:meth:`commit_m`: a cone seen from afar, its position still rough, that narrows the
        lane there; a bend beyond the steering's limit, its inner cone not yet seen), the
        index of the cheapest by its cost before the conflict, set to stand before it; None
        when there is none. The car drives it as far as it could stop, and the next plans
        see that part nearer and better."""
        commit = self.commit_m(horizon_m, speed_mps)
        far = [i for i, cand in enumerate(cands)
               if not cand.leaves_lane and min(cand.hit_m, cand.bent_m) > commit]
        if not far:
            return None
        best = min(far, key=lambda i: cands[i].cost_before_conflict)
        self.rejections["wide: far conflict taken"] += 1
        conflict = min(cands[best].hit_m, cands[best].bent_m)
        cands[best] = replace(cands[best], feasible=True,
                              stand_before_m=max(conflict - self.config.path_step_m, 0.0))
        return best

    @staticmethod
    def stop_path(cands: list[Candidate], stop_room_m: float = 0.0) -> int:
        """The index of the path a stop follows when no candidate is feasible, among those
        that stay in the lane (among all when none does): one that leaves ``stop_room_m`` (m,
        the car's braking distance) before it comes too near a cone (its ``free_m``), or
        else the one that leaves the most; then the one with the most clearance."""
        inside = [i for i, cand in enumerate(cands) if not cand.leaves_lane]
        return max(inside or range(len(cands)),
                   key=lambda i: (min(cands[i].free_m, stop_room_m), cands[i].clearance_m))

    def full_margin_m(self, speed_mps: float) -> float:
        """The hard cone margin (m) of the manoeuvres with the full margin while exploring, the
        car at ``speed_mps``: ``cone_clearance_m``, more by ``cone_clearance_per_mps`` per m/s
        above ``cone_clearance_speed_mps``."""
        c = self.config
        over = max(abs(speed_mps) - c.cone_clearance_speed_mps, 0.0)
        return c.cone_clearance_m + c.cone_clearance_per_mps * over

    def _families(self, speed_mps: float, speed_margin: bool = False
                  ) -> list[tuple[str, FloatArray, float, float, float]]:
        """(name, end offsets (m), horizon (m), speed cap (m/s), full cone margin (m)) in the
        order they are tried; with ``speed_margin`` the full margin is
        :meth:`full_margin_m` at the speed each family is driven at."""
        c = self.config
        horizon = self.horizon_m(speed_mps)
        wide = np.linspace(-c.offsets_wide_max_m, c.offsets_wide_max_m,
                           max(c.offsets_wide_count, 1))
        short = max(0.5 * c.horizon_min_m, 2.0 * c.path_step_m * 4)
        # the full margin at the speed each family is driven at (the fallbacks' cap)
        full = slow = c.cone_clearance_m
        near = c.cone_clearance_near_m
        if speed_margin:
            full = self.full_margin_m(speed_mps)
            slow = self.full_margin_m(min(abs(speed_mps), c.fallback_speed_mps))
        return [
            ("nominal", self.offsets(), horizon, math.inf, full),
            ("wide", wide, horizon, math.inf, full),
            ("short", wide, c.horizon_min_m, c.fallback_speed_mps, slow),
            ("shortest", wide, short, c.fallback_speed_mps, slow),
            ("crawl", wide, c.horizon_min_m, c.crawl_speed_mps, near),
            ("crawl short", wide, short, c.crawl_speed_mps, near),
        ]

    def _family(
        self,
        frame: SplineBaseframe,
        s0_m: float,
        d0_m: float,
        yaw_rad: float,
        speed_mps: float,
        tree: cKDTree | None,
        last_offset_m: float | None,
        start: tuple[float, float] | None,
        offsets: FloatArray,
        horizon: float,
        speed_cap_mps: float,
        margin_m: float,
        walls: FloatArray | None = None,
    ) -> list[Candidate]:
        c = self.config
        if start is not None:
            d0_m, slope0 = float(start[0]), float(start[1])
        else:
            _, _, h0, k0 = frame.sample(s0_m)
            dpsi = math.remainder(yaw_rad - float(h0), 2.0 * math.pi)
            dpsi = float(np.clip(dpsi, -1.2, 1.2))
            slope0 = math.tan(dpsi) * (1.0 - float(k0) * d0_m)
        total = self.length_m(horizon, speed_mps)
        if not frame.closed:  # an open frame ends: so do the candidates
            total = min(total, frame.length_m - s0_m)
            if total < 2.0 * c.path_step_m:
                return []
            horizon = min(horizon, 0.7 * total)
        n = max(int(math.ceil(total / c.path_step_m)), 4)
        u = np.linspace(0.0, total, n + 1)
        in_h = u <= horizon
        # every candidate of the family runs over the same s: the baseframe is sampled once and
        # the candidates' geometry is computed together, each element as it would be alone
        H = horizon
        offs = np.asarray(offsets, np.float64).reshape(-1)
        # cubic d(u) = d0 + slope0 u + a u^2 + b u^3 with d(H) = off, d'(H) = 0
        rhs1 = offs - d0_m - slope0 * H
        rhs2 = -slope0
        a = (3.0 * rhs1 - rhs2 * H) / H**2
        b = (rhs2 * H - 2.0 * rhs1) / H**3
        cubic = d0_m + slope0 * u + a[:, None] * u**2 + b[:, None] * u**3
        d_all = np.where(in_h, cubic, offs[:, None])
        s = s0_m + u
        xy_all = frame.frenet_to_xy(s, d_all)
        heading_all, kappa_all = _path_geometry(xy_all)
        out = None if walls is None or len(walls) == 0 else leaves_through(xy_all, walls)
        return self._grade(offs, s, d_all, xy_all, heading_all, kappa_all, in_h, tree,
                           last_offset_m, speed_mps, margin_m, speed_cap_mps, out)

    def _grade(
        self,
        offsets: FloatArray,
        s: FloatArray,
        d: FloatArray,
        xy: FloatArray,
        heading: FloatArray,
        kappa: FloatArray,
        in_h: NDArray[np.bool_],
        tree: cKDTree | None,
        last_offset_m: float | None,
        speed_mps: float = 0.0,
        margin_m: float | None = None,
        speed_cap_mps: float = math.inf,
        leaves: NDArray[np.bool_] | None = None,
    ) -> list[Candidate]:
        """The checks and cost of candidates to ``offsets`` (C,) over the same ``s`` (K,): d,
        heading, curvature (C, K), xy (C, K, 2); ``margin_m`` the full cone margin (None: the
        configured ``cone_clearance_m``); ``leaves`` (C,): which leave the lane through a
        wall (refused, never taken even as the least bent)."""
        c = self.config
        count, k_len = d.shape
        k_abs = np.abs(kappa[:, 1:-1]) if k_len > 2 else np.abs(kappa)
        kmax_all = k_abs.max(axis=1) if k_abs.shape[1] else np.zeros(count)
        bent_all = kmax_all > self.kappa_max_1pm
        u = s - s[0]
        bent_u = (np.where(bent_all, u[1 + np.argmax(k_abs > self.kappa_max_1pm, axis=1)],
                           math.inf) if k_len > 2 else np.where(bent_all, 0.0, math.inf))
        gap_all: FloatArray | None = None
        if tree is not None:
            cos_h, sin_h = np.cos(heading), np.sin(heading)
            centres = (xy[:, :, None, :] + self.circle_offsets_m[None, None, :, None]
                       * np.stack([cos_h, sin_h], axis=-1)[:, :, None, :]).reshape(-1, 2)
            dist, _ = tree.query(centres, distance_upper_bound=self.required_m + 5.0)
            gap_all = dist.reshape(count, k_len, -1).min(axis=2) - self.circle_radius_m
            ramp = max(c.clearance_ramp_m, abs(speed_mps) * c.clearance_ramp_time_s, 1e-6)
            full = c.cone_clearance_m if margin_m is None else margin_m
            ramp_frac = np.clip(u / ramp, 0.0, 1.0)
        step = float(np.mean(np.diff(s))) if len(s) > 1 else 1.0
        # every candidate's checks and cost at once (numpy over the family, not a loop of
        # small calls per candidate: issue 42)
        offs = np.asarray(offsets, np.float64)
        cost_all = c.weight_curvature * (np.sum(kappa[:, in_h] ** 2, axis=1) * step)
        cost_all = cost_all + c.weight_offset * offs * offs
        if last_offset_m is not None:
            cost_all = cost_all + c.weight_consistency * (offs - last_offset_m) ** 2
        clear_all = np.full(count, math.inf)
        free_all = np.full(count, math.inf)
        worst = np.zeros(count, np.int64)
        hit_all = np.zeros(count, bool)
        hit_u = np.full(count, math.inf)
        cost_before = cost_all
        if gap_all is not None:
            clear_all = gap_all.min(axis=1)
            # the hard margin grows from where the car is now (it is there: no closer than it
            # already stands, if that is inside the near margin) to the full margin ahead; the
            # preferred room is a cost, not a limit
            near = np.minimum(min(c.cone_clearance_near_m, full), np.maximum(gap_all[:, 0], 0.0))
            slack = gap_all - (near[:, None] + (full - near)[:, None] * ramp_frac[None, :])
            worst = np.argmin(slack, axis=1)
            hit_all = slack[np.arange(count), worst] < 0.0
            first_hit = np.argmax(slack < 0.0, axis=1)
            hit_u = np.where(hit_all, u[first_hit], math.inf)
            # a stop stands at the last point before the path comes nearer than the near margin
            # (from where the car stands, less what the circles overstate beside the body: a
            # path along a cone as near by the body as now may read that much nearer)
            stand = np.minimum(c.cone_clearance_near_m, gap_all[:, 0]) - self.circle_overreach_m
            touch = gap_all < stand[:, None]
            first = np.argmax(touch, axis=1)
            free_all = np.where(touch[np.arange(count), first], u[np.maximum(first - 1, 0)],
                                math.inf)
            # before its first conflict (a far one: :meth:`_far_conflict`) the room counts too
            before = u[None, :] < np.minimum(hit_u, bent_u)[:, None]
            clear_before = np.where(before, gap_all, math.inf).min(axis=1)
            short = np.maximum(0.0, c.preferred_clearance_m - clear_all)
            short_before = np.maximum(0.0, c.preferred_clearance_m - clear_before)
            base = cost_all
            cost_all = base + np.where(np.isfinite(clear_all),
                                       c.weight_clearance * short * short, 0.0)
            cost_before = base + np.where(np.isfinite(clear_before),
                                          c.weight_clearance * short_before * short_before, 0.0)
        cands: list[Candidate] = []
        for j in range(count):
            kmax = float(kmax_all[j])
            reason = ""
            if bent_all[j]:
                reason = f"curvature {kmax:.3f} > {self.kappa_max_1pm:.3f} 1/m"
            collision_free = not hit_all[j]
            out = leaves is not None and bool(leaves[j])
            if not collision_free:
                i = int(worst[j])
                reason = f"clearance {gap_all[j, i]:.2f} m to a cone at {u[i]:.1f} m"  # type: ignore[index]
            elif out:
                collision_free = False
                reason = "boundary (leaves the lane between two of its cones)"
            cands.append(Candidate(float(offs[j]), s, d[j], xy[j], heading[j], kappa[j],
                                   float(clear_all[j]), collision_free and not bent_all[j],
                                   float(cost_all[j]), reason, collision_free, kmax,
                                   speed_cap_mps, out, float(free_all[j]), float(hit_u[j]),
                                   float(bent_u[j]), float(cost_before[j])))
        return cands
