"""Building a :class:`~simulator.track.Track` from cones in a file's frame.

A :class:`RawLayout` holds the cones as a file gave them (:mod:`simulator.track_formats`).
:func:`build_track` recognises the layout and builds its centreline and boundaries:

- ``trackdrive``: a closed loop, blue cones on the left, yellow on the right; the centreline is
  built from midpoints between the two ordered boundaries and is a closed loop (``is_loop``).
- ``acceleration``: a straight; the centreline runs from the car's start to the last cone.
- ``skidpad``: the figure of eight; the centreline is the driven path (entry, two right laps,
  two left laps, exit), not a loop.

Everything is then moved into the WORLD frame (:func:`finish_track`): the car's start pose (the
vehicle origin, the rear-axle centre) is (0, 0) with yaw 0. A missing start pose is inferred
from the big orange cones (the car is put on the centreline 6 m before the start line);
anything that cannot be understood raises :class:`common.errors.TrackError` naming the file and
what is wrong.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from common.conventions import wrap_angle
from common.errors import TrackError
from common.messages import ConeColour
from common.polyline import (
    FloatArray,
    IntArray,
    arc_lengths,
    headings,
    nearest_on_polyline,
    polyline_length,
    resample,
    side_of,
    smooth_closed,
    to_pose_frame,
)
from simulator.track import Track, half_widths

log = logging.getLogger(__name__)

START_BEHIND_LINE_M = 6.0
"""Where a car is put when the file has no start pose: this far before the start line."""
CENTRELINE_STEP_M = 0.5
"""Spacing of the centreline samples (m)."""
CHAIN_GAP_M = 12.0
"""The longest gap (m) between neighbours of a boundary's row of cones, its closing gap
included (the start gate's big orange cones stand in the rows there)."""


@dataclass
class RawLayout:
    """Cones as read from a file, in the file's frame."""

    name: str
    source: str
    xy: FloatArray
    colours: IntArray
    sizes: IntArray
    start_pose: tuple[float, float, float] | None  # vehicle origin x, y, yaw in the file frame
    side_hint: IntArray | None = None  # +1 left, -1 right, 0 unknown (FSSIM's explicit sides)


def _order_chain(points: FloatArray, start_xy: FloatArray, start_dir: FloatArray | None,
                 max_gap_m: float = CHAIN_GAP_M) -> list[int]:
    """Order cones into a chain: start at the cone nearest ``start_xy``, then repeatedly the
    nearest unvisited cone that is not behind the current direction of travel."""
    n = len(points)
    if n == 0:
        return []
    d0 = np.hypot(*(points - start_xy).T)
    order = [int(np.argmin(d0))]
    visited = np.zeros(n, bool)
    visited[order[0]] = True
    direction = None
    if start_dir is not None:
        direction = start_dir / max(float(np.linalg.norm(start_dir)), 1e-9)
    while not visited.all():
        cur = points[order[-1]]
        rel = points - cur
        dist = np.hypot(rel[:, 0], rel[:, 1])
        cost = dist.copy()
        cost[visited] = np.inf
        if direction is not None:
            cosang = (rel @ direction) / np.maximum(dist, 1e-9)
            cost = np.where(cosang < -0.3, np.inf, cost)
            cost = cost * (1.0 + 2.0 * (1.0 - np.clip(cosang, -1.0, 1.0)))
        j = int(np.argmin(cost))
        if not np.isfinite(cost[j]) or dist[j] > max_gap_m:
            break
        visited[j] = True
        step = points[j] - cur
        direction = step / max(float(np.linalg.norm(step)), 1e-9)
        order.append(j)
    return order


def _loop_centreline(left: FloatArray, right: FloatArray) -> FloatArray:
    """A closed centreline from two ordered closed boundaries (same direction)."""
    ls = resample(left, 0.25, True)
    rs = resample(right, 0.25, True)
    s_l = arc_lengths(np.vstack([left, left[:1]]))
    s_r = arc_lengths(np.vstack([right, right[:1]]))
    # left samples -> nearest on right
    _, seg_r, t_r, proj_r = nearest_on_polyline(ls, right, True)
    seg_len_r = np.diff(s_r)
    param_l1 = arc_lengths(np.vstack([ls, ls[:1]]))[:-1] * (s_l[-1] / max(
        polyline_length(ls, True), 1e-9))
    param_r1 = s_r[seg_r] + t_r * seg_len_r[seg_r]
    # right samples -> nearest on left
    _, seg_l, t_l, proj_l = nearest_on_polyline(rs, left, True)
    seg_len_l = np.diff(s_l)
    param_l2 = s_l[seg_l] + t_l * seg_len_l[seg_l]
    param_r2 = arc_lengths(np.vstack([rs, rs[:1]]))[:-1] * (s_r[-1] / max(
        polyline_length(rs, True), 1e-9))
    mid = np.vstack([(ls + proj_r) / 2.0, (rs + proj_l) / 2.0])
    p_l = np.concatenate([param_l1, param_l2])
    p_r = np.concatenate([param_r1, param_r2])
    order = np.lexsort((p_r, p_l))
    mid = mid[order]
    mid = smooth_closed(mid, 9)
    mid = resample(mid, CENTRELINE_STEP_M, True)
    return smooth_closed(mid, 5)


def line_from_cluster(
    cluster: FloatArray, heading_rad: float
) -> FloatArray:
    """A start/finish line (2,2) across the track through a cluster of gate cones."""
    mid = cluster.mean(axis=0)
    nx, ny = -math.sin(heading_rad), math.cos(heading_rad)
    lat = (cluster - mid) @ np.array([nx, ny])
    half = max(float(np.abs(lat).max()), 1.0)
    return np.array([[mid[0] - half * nx, mid[1] - half * ny],
                     [mid[0] + half * nx, mid[1] + half * ny]])


def _clusters(points: FloatArray, radius_m: float) -> list[FloatArray]:
    """Simple single-link clusters of points within ``radius_m`` of each other."""
    n = len(points)
    label = -np.ones(n, int)
    k = 0
    for i in range(n):
        if label[i] >= 0:
            continue
        stack = [i]
        label[i] = k
        while stack:
            j = stack.pop()
            near = np.nonzero((np.hypot(*(points - points[j]).T) <= radius_m) & (label < 0))[0]
            label[near] = k
            stack.extend(near.tolist())
        k += 1
    return [points[label == c] for c in range(k)]


def _classify(raw: RawLayout) -> str:
    lname = raw.name.lower()
    if "skidpad" in lname or "skid_pad" in lname:
        return "skidpad"
    if "accel" in lname:
        return "acceleration"
    xy = raw.xy - raw.xy.mean(axis=0)
    if len(xy) >= 4:
        sv = np.linalg.svd(xy, compute_uv=False) / math.sqrt(len(xy))
        if sv[1] < 3.0 and sv[0] > 15.0:
            return "acceleration"
    return "trackdrive"


DUPLICATE_CONE_M = 0.1
"""Two cones of one colour whose centres are nearer than this are one cone written twice (two
real cones' bases, 0.23 m across, cannot stand so near): layouts built from lines and arcs
repeat the cone where two pieces meet (EPFL's track database)."""


def merge_duplicate_cones(raw: RawLayout) -> RawLayout:
    """``raw`` with each cone written twice (:data:`DUPLICATE_CONE_M`) kept once, in file
    order, and how many were dropped logged; the layout itself when there are none."""
    pairs = cKDTree(raw.xy).query_pairs(DUPLICATE_CONE_M, output_type="ndarray")
    same = pairs[raw.colours[pairs[:, 0]] == raw.colours[pairs[:, 1]]] if len(pairs) else pairs
    if not len(same):
        return raw
    keep = np.ones(len(raw.xy), bool)
    keep[np.maximum(same[:, 0], same[:, 1])] = False
    log.warning("%s: %d cones written twice (same colour, centres under %.2f m apart) kept once",
                raw.source, int((~keep).sum()), DUPLICATE_CONE_M)
    hint = raw.side_hint[keep] if raw.side_hint is not None else None
    return RawLayout(raw.name, raw.source, raw.xy[keep], raw.colours[keep], raw.sizes[keep],
                     raw.start_pose, hint)


def build_track(raw: RawLayout) -> Track:
    """Turn cones in a file frame into a world-frame :class:`Track` (kind auto-detected; a
    cone written twice is kept once)."""
    raw = merge_duplicate_cones(raw)
    if len(raw.xy) < 4:
        raise TrackError(f"{raw.source}: only {len(raw.xy)} cones, a track needs at least 4")
    kind = _classify(raw)
    if kind == "acceleration":
        return _build_acceleration(raw)
    if kind == "skidpad":
        return _build_skidpad(raw)
    return _build_trackdrive(raw)


def finish_track(raw: RawLayout, kind: str, pose: tuple[float, float, float], centre: FloatArray,
            left: FloatArray, right: FloatArray, is_loop: bool,
            start_line: FloatArray, finish_line: FloatArray) -> Track:
    """Move everything into the frame of ``pose`` and make the Track."""
    def tf(a: FloatArray) -> FloatArray:
        return to_pose_frame(a, pose) if len(a) else np.zeros((0, 2))

    centre_w = tf(centre)
    if is_loop:
        # start the centreline at the sample nearest the car, oriented with the car
        k = int(np.argmin(np.hypot(*centre_w.T)))
        centre_w = np.roll(centre_w, -k, axis=0)
    left_w, right_w = tf(left), tf(right)
    if kind == "skidpad":
        width_m = 3.0
    else:
        left_hw, right_hw = half_widths(centre_w, left_w, right_w, kind, is_loop)
        width_m = float(np.median(left_hw + right_hw))
    return Track(
        name=raw.name,
        cones_xy_m=tf(raw.xy),
        colours=raw.colours,
        sizes=raw.sizes,
        centreline_xy_m=centre_w,
        left_xy_m=left_w,
        right_xy_m=right_w,
        width_m=width_m,
        is_loop=is_loop,
        lap_length_m=polyline_length(centre_w, is_loop),
        kind=kind,
        start_line_xy_m=tf(start_line) if np.all(np.isfinite(start_line)) else start_line,
        finish_line_xy_m=tf(finish_line) if np.all(np.isfinite(finish_line)) else finish_line,
        source=raw.source,
    )


def _build_trackdrive(raw: RawLayout) -> Track:
    xy, col = raw.xy, raw.colours
    left_mask = col == ConeColour.BLUE
    right_mask = col == ConeColour.YELLOW
    if raw.side_hint is not None:
        left_mask = left_mask | (raw.side_hint > 0)
        right_mask = right_mask | (raw.side_hint < 0)
    if left_mask.sum() < 3 or right_mask.sum() < 3:
        raise TrackError(
            f"{raw.source}: a trackdrive needs at least 3 blue (left) and 3 yellow (right) cones,"
            f" got {int(left_mask.sum())} and {int(right_mask.sum())}")
    big = xy[col == ConeColour.BIG_ORANGE]
    if raw.start_pose is not None:
        start_xy = np.array(raw.start_pose[:2])
        start_dir: FloatArray | None = np.array([math.cos(raw.start_pose[2]),
                                                 math.sin(raw.start_pose[2])])
    elif len(big):
        start_xy = big.mean(axis=0)
        start_dir = None
    else:
        start_xy = xy[left_mask][0]
        start_dir = None
    lpts, rpts = xy[left_mask], xy[right_mask]
    lorder = _order_chain(lpts, start_xy, start_dir)
    ldir = lpts[lorder[1]] - lpts[lorder[0]] if len(lorder) > 1 else start_dir
    rorder = _order_chain(rpts, lpts[lorder[0]], ldir)
    for side, order, pts in (("left", lorder, lpts), ("right", rorder, rpts)):
        if len(order) < 0.8 * len(pts) or len(order) < 3:
            raise TrackError(
                f"{raw.source}: cannot order the {side} cones into one boundary"
                f" ({len(order)} of {len(pts)} chained; gaps over 12 m?)")
        if len(order) < len(pts):
            log.warning("%s: %d %s cones left out of the boundary chain", raw.source,
                        len(pts) - len(order), side)
        ends_m = float(np.hypot(*(pts[order[-1]] - pts[order[0]])))
        if ends_m > CHAIN_GAP_M:
            raise TrackError(
                f"{raw.source}: not a closed loop: the {side} cones' row ends {ends_m:.1f} m from"
                f" where it starts (a closed track's rows close within {CHAIN_GAP_M:.0f} m);"
                " trackdrive and autocross need a closed track")
    left, right = lpts[lorder], rpts[rorder]
    centre = _loop_centreline(left, right)
    # orient: blue on the left
    lat_l, _ = side_of(lpts, centre, True)
    if np.median(lat_l) < 0.0:
        centre = centre[::-1].copy()
    # side of every cone, and boundaries ordered along the centreline
    lat, s = side_of(xy, centre, True)
    cone_side = np.where(left_mask, 1, np.where(right_mask, -1, np.sign(lat))).astype(int)
    lsel = np.nonzero(cone_side > 0)[0]
    rsel = np.nonzero(cone_side < 0)[0]
    left = xy[lsel[np.argsort(s[lsel], kind="stable")]]
    right = xy[rsel[np.argsort(s[rsel], kind="stable")]]
    centre_heading = headings(centre, True)
    # start line from the big orange cones (the cluster nearest the start)
    start_line = np.full((2, 2), np.nan)
    if len(big) >= 2:
        clusters = _clusters(big, 7.0)
        ref = start_xy
        gate = min(clusters, key=lambda c: float(np.hypot(*(c.mean(axis=0) - ref))))
        if len(gate) >= 2:
            _, gs = side_of(gate.mean(axis=0)[None], centre, True)
            k = int(np.argmin(np.hypot(*(centre - gate.mean(axis=0)).T)))
            start_line = line_from_cluster(gate, float(centre_heading[k]))
    pose = raw.start_pose
    if pose is None:
        pose = _inferred_pose(raw, centre, centre_heading, start_line)
    else:
        k = int(np.argmin(np.hypot(*(centre - np.array(pose[:2])).T)))
        if abs(wrap_angle(float(centre_heading[k]) - pose[2])) > math.pi / 2:
            log.warning("%s: the start pose faces against the blue-left direction", raw.source)
    return finish_track(raw, "trackdrive", pose, centre, left, right, True, start_line, start_line)


def _inferred_pose(raw: RawLayout, centre: FloatArray, heading: FloatArray,
                   start_line: FloatArray) -> tuple[float, float, float]:
    if np.all(np.isfinite(start_line)):
        k = int(np.argmin(np.hypot(*(centre - start_line.mean(axis=0)).T)))
    else:
        k = 0
    back = int(round(START_BEHIND_LINE_M / CENTRELINE_STEP_M))
    j = (k - back) % len(centre)
    log.info("%s: no start pose in the file; starting %.1f m before the start line",
             raw.source, START_BEHIND_LINE_M)
    return float(centre[j, 0]), float(centre[j, 1]), float(heading[j])


def _build_acceleration(raw: RawLayout) -> Track:
    xy = raw.xy
    mean = xy.mean(axis=0)
    _, _, vt = np.linalg.svd(xy - mean)
    axis = vt[0]
    if raw.start_pose is not None:
        sx, sy, syaw = raw.start_pose
        if axis @ np.array([math.cos(syaw), math.sin(syaw)]) < 0:
            axis = -axis
    else:
        big = xy[raw.colours == ConeColour.BIG_ORANGE]
        along_all = (xy - mean) @ axis
        ref = big if len(big) else xy
        # start at the end where the big orange cones are (or the first cones)
        if ((ref - mean) @ axis).min() > along_all.min() + 0.5 * np.ptp(along_all):
            axis = -axis
    normal = np.array([-axis[1], axis[0]])
    along = (xy - mean) @ axis
    lat = (xy - mean) @ normal
    if raw.start_pose is None:
        big = raw.colours == ConeColour.BIG_ORANGE
        first = float(along[big].min()) if big.any() else float(along.min())
        s0 = first - START_BEHIND_LINE_M
        p = mean + s0 * axis
        pose = (float(p[0]), float(p[1]), math.atan2(axis[1], axis[0]))
        log.info("%s: no start pose in the file; starting %.1f m before the first gate",
                 raw.source, START_BEHIND_LINE_M)
    else:
        pose = raw.start_pose
    s_start = float((np.array(pose[:2]) - mean) @ axis)
    s_end = float(along.max())
    n = max(int(round((s_end - s_start) / CENTRELINE_STEP_M)), 2)
    q = np.linspace(s_start, s_end, n + 1)
    centre = mean + q[:, None] * axis[None, :]
    left_sel = np.nonzero(lat > 0)[0]
    right_sel = np.nonzero(lat <= 0)[0]
    left = xy[left_sel[np.argsort(along[left_sel])]]
    right = xy[right_sel[np.argsort(along[right_sel])]]
    heading = math.atan2(axis[1], axis[0])
    start_line = np.full((2, 2), np.nan)
    finish_line = np.full((2, 2), np.nan)
    big_pts = xy[raw.colours == ConeColour.BIG_ORANGE]
    if len(big_pts) >= 2:
        gates = sorted(_clusters(big_pts, 7.0), key=lambda c: float((c.mean(axis=0) - mean)
                                                                     @ axis))
        start_line = line_from_cluster(gates[0], heading)
        finish_line = line_from_cluster(gates[-1], heading) if len(gates) > 1 else start_line
    return finish_track(raw, "acceleration", pose, centre, left, right, False, start_line,
                   finish_line)


def _fit_circle(pts: FloatArray) -> tuple[FloatArray, float]:
    """Algebraic (Kasa) circle fit: centre (2,), radius."""
    a = np.column_stack([2 * pts[:, 0], 2 * pts[:, 1], np.ones(len(pts))])
    b = (pts ** 2).sum(axis=1)
    sol, *_ = np.linalg.lstsq(a, b, rcond=None)
    c = sol[:2]
    return c, float(math.sqrt(max(sol[2] + c @ c, 0.0)))


def _build_skidpad(raw: RawLayout) -> Track:
    xy, col = raw.xy, raw.colours
    big = xy[col == ConeColour.BIG_ORANGE]
    if raw.start_pose is not None:
        pose0 = raw.start_pose
    elif len(big):
        # unknown heading: assume the car drives towards the gate from the far side
        g = big.mean(axis=0)
        pose0 = (float(g[0]), float(g[1]), 0.0)
    else:
        raise TrackError(f"{raw.source}: skidpad without start pose or big orange gate")
    w = to_pose_frame(xy, pose0)
    centres: list[FloatArray] = []
    radii: list[float] = []
    for sign in (-1.0, 1.0):  # right circle (y < 0) first, then left
        side = (w[:, 1] * sign > 1.0)
        best: tuple[FloatArray, float] | None = None
        for colour in (ConeColour.BLUE, ConeColour.YELLOW):
            pts = w[side & (col == colour)]
            if len(pts) >= 5:
                c, r = _fit_circle(pts)
                if best is None or r < best[1]:
                    best = (c, r)
        if best is None:
            raise TrackError(f"{raw.source}: skidpad circles not found (too few blue/yellow"
                             f" cones on one side)")
        inner_c, inner_r = best
        ring = w[side & ((col == ConeColour.BLUE) | (col == ConeColour.YELLOW))]
        d = np.hypot(*(ring - inner_c).T)
        outer = d[d > inner_r + 1.0]
        outer_r = float(np.median(outer)) if len(outer) else inner_r + 3.0
        centres.append(inner_c)
        radii.append(0.5 * (inner_r + outer_r))
    cr, cl = centres
    r = 0.5 * (radii[0] + radii[1])
    x_cross = 0.5 * (cr[0] + cl[0])
    y_cross = 0.5 * (cr[1] + cl[1])
    parts: list[FloatArray] = []
    # entry straight
    n_in = max(int(x_cross / CENTRELINE_STEP_M), 2)
    parts.append(np.column_stack([np.linspace(0.0, x_cross, n_in, endpoint=False),
                                np.linspace(0.0, y_cross, n_in, endpoint=False)]))
    n_c = max(int(2 * math.pi * r / CENTRELINE_STEP_M), 8)
    ang = np.linspace(0.0, 4 * math.pi, 2 * n_c, endpoint=False)
    # right circle, clockwise, starting at the top of it (the crossing point)
    a0 = math.atan2(y_cross - cr[1], x_cross - cr[0])
    parts.append(np.column_stack([cr[0] + r * np.cos(a0 - ang), cr[1] + r * np.sin(a0 - ang)]))
    a1 = math.atan2(y_cross - cl[1], x_cross - cl[0])
    parts.append(np.column_stack([cl[0] + r * np.cos(a1 + ang), cl[1] + r * np.sin(a1 + ang)]))
    far = float(w[:, 0].max()) - 3.0  # end of the exit lane, short of the last cones
    n_out = max(int((far - x_cross) / CENTRELINE_STEP_M), 2)
    parts.append(np.column_stack([np.linspace(x_cross, far, n_out),
                                np.full(n_out, y_cross)]))
    centre_w = np.vstack(parts)
    # back to the file frame so finish_track can transform uniformly
    c0, s0 = math.cos(pose0[2]), math.sin(pose0[2])
    centre = np.column_stack([pose0[0] + centre_w[:, 0] * c0 - centre_w[:, 1] * s0,
                              pose0[1] + centre_w[:, 0] * s0 + centre_w[:, 1] * c0])
    left = xy[col == ConeColour.BLUE]
    right = xy[col == ConeColour.YELLOW]
    start_line = np.full((2, 2), np.nan)
    if len(big) >= 2:
        start_line = line_from_cluster(big, pose0[2])
    return finish_track(raw, "skidpad", pose0, centre, left, right, False, start_line, start_line)
