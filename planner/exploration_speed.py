"""The speed limit on a track not seen before: set by what the car has seen (issue 45).

One invariant, kept here: **the car can always stop within the part of the track it has
mapped.** Along the exploring frame (the path through the cones seen so far, which ends where
they end) the speed at arc length ``s`` is at most what lets the car drive on for the late
cover (a plan followed that late, ``planner.exploration_late_cover_s``) and then make the
safety supervisor's controlled stop (its reaction, margin and deceleration: the room a late
plan must leave, handed in by Main) within the frame's remaining length. Nothing else caps the
pace but a sanity top speed (``planner.exploration_speed_mps``), a narrow passage's speed,
and the friction circle, the steering's rate and its lock on the path's curvature
(:mod:`planner.speed_profile`), the friction circle at a share of the lateral limit that
grows with the room beside the path (:func:`room_lateral_factor`). How far
ahead the cones are seen (the perception's range, about 14-15 m from the car with the
simulated VLP-16 low at the front) thus sets the pace on the straights.

The controller asks for the profile's speed a little ahead of the car (its speed preview,
``controller.speed_preview_s``, against the speed loop's lag) and feeds forward the profile's
slope over the half second beyond. Near the end of the seen track those points are nearer the
end than the car: asking the invariant there held the car a preview's worth of room short of
what the invariant at the car allows and braked it all the time, on every metre of an unseen
lap, for an end that moves on as cones come into view (FSG autocross, seed 1: 49.7 s). So
over ``lead_s`` of driving ahead of the car (at the speed it may drive there) the limit is the
invariant's at the car itself (never more), and beyond, the invariant of a point that much
nearer the car (42.8 s); the profile's own standstill at the end of the frame is shifted by
the same lead (:func:`exploring_end_speed_mps`). The car then holds the speed it may drive
where it is, and brakes when no new cones come into view and its own room shrinks. The
supervisor's stop (8 m/s^2, after its reaction, with the late cover) stays inside the brakes'
12 m/s^2, so the speed loop's lag (up to 1 m/s over the limit at the car on FSG) does not take
the car past where it can stop.

The path's curvature through cones seen partly (a gate's cone placed a few centimetres off,
a side seen from far away) carries noise that a bend does not: a curvature spike over a metre
or two asks for a dip in the speed that the car cannot and need not drive.
:func:`speed_curvature` takes off the peaks narrower than ``exploration_curvature_window_m``
for the speed alone (a bend keeps its curvature); the manoeuvres are still checked against
their own curvature.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from common.proximity import pairs_within
from planner.baseframe import SplineBaseframe
from planner.config import PlannerConfig

if TYPE_CHECKING:
    from planner.manoeuvres import ManoeuvreGenerator

FloatArray = NDArray[np.float64]


def stop_room_m(speed_mps: ArrayLike, late_s: float, reaction_s: float, margin_m: float,
                decel_mps2: float) -> FloatArray:
    """The room (m) a car at ``speed_mps`` needs to drive on ``late_s`` + ``reaction_s`` and
    then stop at ``decel_mps2``, plus ``margin_m``: the invariant's measure."""
    v = np.maximum(np.asarray(speed_mps, np.float64), 0.0)
    return np.asarray(v * (late_s + reaction_s) + v * v / (2.0 * decel_mps2) + margin_m,
                      np.float64)


def seen_track_speed_mps(remaining_m: ArrayLike, room_m: FloatArray, speed_mps: FloatArray,
                         top_speed_mps: float = math.inf, lead_m: ArrayLike = 0.0) -> FloatArray:
    """The highest speed (m/s) at each point ``remaining_m`` (m) short of the end of the seen
    track that still leaves the room to stop there: the inverse of the table (``room_m``,
    ``speed_mps``), both increasing (:func:`planner.speed_profile.late_cover_table`, or
    :func:`stop_room_m` on a grid of speeds), capped at ``top_speed_mps``. ``lead_m`` (m,
    scalar or per point): the point the speed is asked for lies that far ahead of the car (the
    controller's speed preview), so the room counted is that much more (it is the car's).
    An empty table: no limit but the top speed. Zero past the end, and at it without a lead."""
    rem = np.asarray(remaining_m, np.float64)
    if len(room_m) == 0:
        return np.full(rem.shape, float(top_speed_mps))
    room = np.maximum(rem, 0.0) + np.maximum(np.asarray(lead_m, np.float64), 0.0)
    v = np.interp(room, room_m, speed_mps, left=0.0)
    v = np.where(rem >= 0.0, v, 0.0)  # at the end itself the room is the lead's alone
    return np.asarray(np.minimum(v, top_speed_mps), np.float64)


def view_speed_mps(view_m: float, room_m: FloatArray, speed_mps: FloatArray) -> float:
    """The speed (m/s) the invariant allows a car with ``view_m`` (m) of seen track ahead
    (:func:`seen_track_speed_mps` with no lead, no top speed): the pace ``view_m`` of track in
    view allows on a straight."""
    return float(seen_track_speed_mps(np.array([view_m]), room_m, speed_mps)[0])


def preview_lead_m(speed_mps: ArrayLike, lead_s: float, max_lead_m: float) -> FloatArray:
    """How far ahead of the car (m) the controller reads the speed it is asked for at
    ``speed_mps``: ``lead_s`` of driving, at most ``max_lead_m``."""
    v = np.maximum(np.asarray(speed_mps, np.float64), 0.0)
    return np.asarray(np.minimum(v * max(lead_s, 0.0), max_lead_m), np.float64)


def speed_limit_along_mps(s_m: FloatArray, length_m: float, room_m: FloatArray,
                          speed_mps: FloatArray, top_speed_mps: float, car_s_m: float = 0.0,
                          lead_s: float = 0.0, max_lead_m: float = 0.0) -> FloatArray:
    """The invariant's speed limit (M,) (m/s) along an exploring frame sampled at ``s_m`` (m)
    of total length ``length_m``, the car at ``car_s_m``: never more than the car may drive
    where it is (:func:`seen_track_speed_mps` of its remaining length); ahead of it, what
    the invariant allows a point :func:`exploring_lead_m` nearer the car (the distance the
    controller reads its speed and slope over, at the speed the car may drive). So the speed
    the controller reads up to that far ahead of the car, and its slope there, are the
    invariant's at the car: the car holds the speed it may drive, instead of braking all the
    time for an end of the track that moves on as cones come into view."""
    return _limit_and_lead(s_m, length_m, room_m, speed_mps, top_speed_mps, car_s_m, lead_s,
                           max_lead_m)[0]


def _limit_and_lead(s_m: FloatArray, length_m: float, room_m: FloatArray,
                    speed_mps: FloatArray, top_speed_mps: float, car_s_m: float,
                    lead_s: float, max_lead_m: float) -> tuple[FloatArray, float]:
    """:func:`speed_limit_along_mps` and the lead (m) it shifted the invariant by."""
    remaining = length_m - np.asarray(s_m, np.float64)
    at_car = float(seen_track_speed_mps(np.array([length_m - car_s_m]), room_m, speed_mps,
                                        top_speed_mps)[0])
    lead = exploring_lead_m(at_car, lead_s, max_lead_m)
    v = seen_track_speed_mps(remaining, room_m, speed_mps, top_speed_mps, lead)
    return np.asarray(np.minimum(v, at_car), np.float64), lead


def exploring_lead_m(at_car_mps: float, lead_s: float, max_lead_m: float) -> float:
    """How far (m) the exploring speed limit is shifted ahead of where it holds: the
    controller's reach (``lead_s`` of driving, at most ``max_lead_m``) at the speed the car
    may drive where it is, ``at_car_mps`` (m/s). One distance for the whole frame, the
    standstill at its end included (:func:`exploring_end_speed_mps`): a lead that shrank with
    each point's own speed put the slope of a stop just inside the controller's reach, and
    the car braked for it at every plan (gen:10 autocross, seed 1, with the supervisor's
    stop at 10 m/s^2: 11-12 m/s where the invariant allowed 13-14)."""
    return float(preview_lead_m(at_car_mps, lead_s, max_lead_m))


def exploring_end_speed_mps(lead_m: float, brake_mps2: float) -> float:
    """The speed (m/s) the profile of an exploring frame ends at: a standstill
    :func:`exploring_lead_m` beyond its end at the profile's braking ``brake_mps2`` (m/s^2),
    the same shift as the invariant's. That the car stops within the track seen is the
    invariant's to keep, at the car itself."""
    return math.sqrt(2.0 * max(brake_mps2, 0.0) * max(lead_m, 0.0))


def speed_curvature(kappa_1pm: ArrayLike, step_m: float, window_m: float) -> FloatArray:
    """The curvature (1/m) the speed of an exploring path is set from: ``kappa_1pm`` sampled
    every ``step_m`` with every peak narrower than ``window_m`` (m) taken off (a grey opening,
    the bends to the left and to the right apart): a kink of the path through cones seen
    partly goes, a bend as long as the window or longer keeps its full curvature (a hairpin's
    does: a Gaussian smoothing over 1 m took enough off the rules' tightest hairpin to hit
    its cones) and a change of direction its full swing. 0: as it is."""
    k = np.asarray(kappa_1pm, np.float64)
    n = int(round(window_m / step_m)) if step_m > 0.0 else 0
    if n < 2 or len(k) < 3:
        return k.copy()
    from scipy.ndimage import grey_opening  # local: only the profile needs it

    left = grey_opening(np.maximum(k, 0.0), size=n, mode="nearest")
    right = grey_opening(np.maximum(-k, 0.0), size=n, mode="nearest")
    return np.asarray(left - right, np.float64)


def exploring_speed_limit_mps(frame: SplineBaseframe, car_xy: tuple[float, float] | None,
                              room_m: FloatArray, speed_mps: FloatArray, config: PlannerConfig,
                              brake_mps2: float) -> tuple[FloatArray, float, float]:
    """:func:`speed_limit_along_mps` along the exploring ``frame`` with the car at ``car_xy``
    (m; None: at the frame's start) and the planner's configuration: top speed
    ``exploration_speed_mps``, lead ``exploration_speed_lead_s`` (at most
    ``exploration_speed_lead_max_m``). ``room_m``, ``speed_mps``: the late cover's table
    (:func:`planner.speed_profile.late_cover_table`). Also the speed (m/s) the profile ends
    at (:func:`exploring_end_speed_mps` at the profile's braking ``brake_mps2``), and the
    seen track ahead of the car (m): the frame's length beyond the car."""
    car_s = 0.0
    if car_xy is not None and all(math.isfinite(v) for v in car_xy):
        car_s = float(frame.project(*car_xy)[0])
    limit, lead = _limit_and_lead(frame.s_m, float(frame.s_m[-1]), room_m, speed_mps,
                                  config.exploration_speed_mps, car_s,
                                  config.exploration_speed_lead_s,
                                  config.exploration_speed_lead_max_m)
    view_m = float(frame.s_m[-1]) - car_s
    if len(room_m) == 0:  # no stop rule handed in: the profile stands at the end itself
        return limit, 0.0, view_m
    return limit, exploring_end_speed_mps(lead, brake_mps2), view_m


def exploring_curvature(kappa_1pm: FloatArray, step_m: float, config: PlannerConfig
                        ) -> tuple[FloatArray, FloatArray]:
    """The curvatures (1/m) the speed of an exploring frame is set from: (the friction
    circle's and the steering lock's, the steering rate's). Over the first
    ``exploration_start_m`` both are the curvature just beyond (the path bends from where the
    car is to the middle of the track, which the manoeuvre does, checked against its own
    curvature); then :func:`speed_curvature` with ``exploration_curvature_window_m``; the
    steering rate's is also smoothed by a Gaussian of ``exploration_rate_sigma_m`` (m): the
    rate is the curvature's slope, which the kinks of a path through cones seen partly make
    steep without a bend's change of steering (a bend's own curvature, its peak, is left to
    the other two limits)."""
    kappa = np.array(kappa_1pm, np.float64)
    if len(kappa) == 0:
        return kappa, kappa.copy()
    n0 = min(int(config.exploration_start_m / step_m), len(kappa) - 1)
    kappa[:n0] = kappa[n0]
    kappa = speed_curvature(kappa, step_m, config.exploration_curvature_window_m)
    sigma = config.exploration_rate_sigma_m / step_m
    if sigma <= 0.0 or len(kappa) < 3:
        return kappa, kappa.copy()
    from scipy.ndimage import gaussian_filter1d  # local: only the profile needs it

    return kappa, np.asarray(gaussian_filter1d(kappa, sigma, mode="nearest"), np.float64)



def passage_room_m(xy_m: FloatArray, heading_rad: FloatArray, cones_xy_m: FloatArray,
                   circle_offsets_m: ArrayLike, required_m: float, max_offset_m: float
                   ) -> FloatArray:
    """The room about the path (M,) (m) at each of its points ``xy_m`` (M, 2) with
    ``heading_rad`` (M,): twice the lateral distance the path could move either way before
    the circles covering the car's body (centres ``circle_offsets_m`` ahead of the reference
    point along the heading) come within ``required_m`` of a cone centre of ``cones_xy_m``
    (N, 2), the manoeuvres' check (:class:`planner.manoeuvres.ManoeuvreGenerator`) with the
    body held parallel to the path; at most ``2 max_offset_m``. 0: the path itself is within
    that of a cone (a manoeuvre must swerve from it). Twice the nearer side, not the two
    sides' sum: the car at speed follows the path, and passes the nearer side's cones (the
    sum let EUFS Hairpin's explored lap run 5 % faster, and hit cones on EPFL Vaudoise in 3
    of 12 seeds)."""
    left, right, blocked = free_sides_m(xy_m, heading_rad, cones_xy_m, circle_offsets_m,
                                        required_m, max_offset_m)
    room = 2.0 * np.minimum(left, right)
    room[blocked] = 0.0  # the path itself is too near a cone
    return room


def free_sides_m(xy_m: FloatArray, heading_rad: FloatArray, cones_xy_m: FloatArray,
                 circle_offsets_m: ArrayLike, required_m: float, max_offset_m: float
                 ) -> tuple[FloatArray, FloatArray, NDArray[np.bool_]]:
    """How far (m) the path's points ``xy_m`` (M, 2) with ``heading_rad`` (M,) could move to
    the left and to the right (M,) each, at most ``max_offset_m``, before the body's circles
    (:func:`passage_room_m`) come within ``required_m`` of a cone of ``cones_xy_m`` (N, 2);
    and where (M,) the point itself is that near one already."""
    xy = np.asarray(xy_m, np.float64).reshape(-1, 2)
    m = len(xy)
    left = np.full(m, float(max_offset_m))
    right = np.full(m, float(max_offset_m))
    blocked = np.zeros(m, bool)
    cones = np.asarray(cones_xy_m, np.float64).reshape(-1, 2)
    if m == 0 or len(cones) == 0:
        return left, right, blocked
    offs = np.asarray(circle_offsets_m, np.float64)
    mid = 0.5 * (float(offs.max()) + float(offs.min()))
    reach = 0.5 * (float(offs.max()) - float(offs.min())) + required_m + max_offset_m
    cos_h, sin_h = np.cos(heading_rad), np.sin(heading_rad)
    centres = xy + mid * np.stack([cos_h, sin_h], axis=1)
    point, cone = pairs_within(centres, cones, reach)  # every (point, cone in reach) pair
    if len(point) == 0:
        return left, right, blocked
    rel = cones[cone] - xy[point]
    c, s = cos_h[point], sin_h[point]
    along = rel[:, 0] * c + rel[:, 1] * s
    across = -rel[:, 0] * s + rel[:, 1] * c
    w = along[:, None] - offs[None, :]  # (pairs, K): each cone from each circle, along
    half = np.sqrt(np.maximum(required_m * required_m - w * w, 0.0)).max(axis=1)
    hit = half > 0.0  # the widest circle's reach across
    point, lo_m, hi_m = point[hit], across[hit] - half[hit], across[hit] + half[hit]
    np.minimum.at(left, point[lo_m > 0.0], lo_m[lo_m > 0.0])
    np.minimum.at(right, point[hi_m < 0.0], -hi_m[hi_m < 0.0])
    blocked[point[(lo_m <= 0.0) & (hi_m >= 0.0)]] = True
    return left, right, blocked


def narrow_passage_speed_mps(room_m: FloatArray, narrow_room_m: float, speed_mps: float
                             ) -> FloatArray:
    """The speed limit (M,) (m/s) of a narrow passage: ``speed_mps`` where the path's
    ``room_m`` (:func:`passage_room_m`) is below ``narrow_room_m``, elsewhere none (inf).
    There a manoeuvre passes a cone with little more than the cone's margin, and at speed the
    car follows its path in a bend to 0.1-0.3 m, no nearer."""
    narrow = np.asarray(room_m, np.float64) < narrow_room_m
    return np.asarray(np.where(narrow, speed_mps, np.inf), np.float64)


ROOM_STEP_M = 0.5
"""The spacing (m) of the points along an exploring path whose room is measured: the
circles covering the car's body are 0.58 m apart."""


def passage_room_along_m(frame: SplineBaseframe, cones_xy_m: FloatArray | None,
                         generator: ManoeuvreGenerator, config: PlannerConfig
                         ) -> FloatArray | None:
    """The room (M,) (m) at each point of the exploring ``frame`` among ``cones_xy_m`` (N, 2)
    (:func:`passage_room_m`): measured every :data:`ROOM_STEP_M` with the manoeuvres' circles
    and full margin (``generator``) over their widest offsets (``offsets_wide_max_m``), each
    point taking the lesser room of the measured points on either side. None without cones."""
    m = len(frame.s_m)
    if cones_xy_m is None or len(cones_xy_m) == 0 or m == 0:
        return None
    stride = max(int(round(ROOM_STEP_M / frame.step_m)), 1)
    idx = np.arange(0, m, stride)
    if idx[-1] != m - 1:
        idx = np.append(idx, m - 1)
    room = passage_room_m(frame.xy_m[idx], frame.heading_rad[idx], cones_xy_m,
                          generator.circle_offsets_m, generator.required_m,
                          config.offsets_wide_max_m)
    k = np.searchsorted(idx, np.arange(m), side="right") - 1  # the measured point behind
    return np.minimum(room[k], room[np.minimum(k + 1, len(idx) - 1)])


def narrow_passage_limit_mps(frame: SplineBaseframe, cones_xy_m: FloatArray | None,
                             generator: ManoeuvreGenerator, config: PlannerConfig,
                             room_m: FloatArray | None = None) -> FloatArray:
    """:func:`narrow_passage_speed_mps` along the exploring ``frame`` among ``cones_xy_m``
    (N, 2), with its room from :func:`passage_room_along_m` (or ``room_m`` (M,), that room
    measured already): narrow below ``exploration_narrow_room_m``, driven at
    ``exploration_narrow_speed_mps``. A narrow room of 0 or no cones: no limit. The planner
    hands the map's cones on every plan, landmarks and the camera's tentative cones alike: a
    limit that held only while tentative cones were in the map came and went between plans,
    and the car sped up into a narrow bend between them (EUFS small_track_2, seed 3: 7.4 m/s,
    then a fallback capped at 4 m/s, 0.008 m from a cone)."""
    c = config
    if room_m is None:
        room_m = passage_room_along_m(frame, cones_xy_m, generator, c)
    if room_m is None or c.exploration_narrow_room_m <= 0.0:
        return np.full(len(frame.s_m), np.inf)
    return narrow_passage_speed_mps(room_m, c.exploration_narrow_room_m,
                                    c.exploration_narrow_speed_mps)


def room_lateral_factor(room_m: ArrayLike, config: PlannerConfig) -> FloatArray:
    """The fraction of the car's lateral limit the exploring profile plans with where the path
    has ``room_m`` (m, :func:`passage_room_m`): ``lateral_safety_factor`` up to
    ``exploration_tight_room_m`` (a lane as narrow as the rules allow),
    :func:`wide_lateral_factor` from ``exploration_wide_room_m`` on, in proportion between.
    At speed in a bend the car strays from its plan by 0.1-0.5 m (more as the plans
    move with the cones coming into view); a wide lane has room for that, the rules' 3 m lane
    does not."""
    c = config
    span = max(c.exploration_wide_room_m - c.exploration_tight_room_m, 1e-9)
    share = np.clip((np.asarray(room_m, np.float64) - c.exploration_tight_room_m) / span,
                    0.0, 1.0)
    return np.asarray(c.lateral_safety_factor + share * (
        wide_lateral_factor(c) - c.lateral_safety_factor), np.float64)


def wide_lateral_factor(config: PlannerConfig) -> float:
    """The exploring profile's fraction of the lateral limit where the path has room:
    ``exploration_lateral_safety_factor``, never less than ``lateral_safety_factor`` (a tuned
    ``lateral_safety_factor`` above it holds everywhere)."""
    return max(config.exploration_lateral_safety_factor, config.lateral_safety_factor)


ROOM_WINDOW_M = 2.5
"""The lateral factor reads the least room within this (m) either side along the path: half
the rules' longest cone spacing (5 m), so that between two cones of a lane no wider than the
rules' narrowest (where the room peaks: 1.12 m in a 3 m lane's bend, 0.73 m abreast its cones)
it is the lane's, not the gap's."""


def room_scaled_curvature(kappa_1pm: ArrayLike, room_m: FloatArray | None,
                          config: PlannerConfig, step_m: float) -> FloatArray:
    """The curvature (M,) (1/m) the exploring profile's friction circle reads for the path's
    ``kappa_1pm`` (M,) (samples ``step_m`` apart) where it has ``room_m`` (M,) (m; None: room
    everywhere): scaled by :func:`wide_lateral_factor` over :func:`room_lateral_factor` of the
    least room within :data:`ROOM_WINDOW_M`. A point mass planned at that factor of the
    lateral limit then corners, and brakes into and through a bend, as one planned at the
    room's own factor would: where the lane is as narrow as the rules allow, exactly as with
    ``lateral_safety_factor`` alone."""
    kappa = np.asarray(kappa_1pm, np.float64)
    if room_m is None:
        return kappa.copy()
    from scipy.ndimage import minimum_filter1d  # local: only the exploring profile needs it

    half = max(int(round(ROOM_WINDOW_M / max(step_m, 1e-9))), 0)
    least = minimum_filter1d(np.asarray(room_m, np.float64), 2 * half + 1, mode="nearest")
    factor = room_lateral_factor(least, config)
    return np.asarray(kappa * (wide_lateral_factor(config) / factor), np.float64)
