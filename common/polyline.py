"""Polylines in the plane: projection, arc length, resampling, smoothing, curvature.

A polyline is an (N, 2) float array of vertices in order; ``closed`` means the last vertex
connects back to the first (the first vertex is not repeated). Lengths in metres, angles in
radians, curvature in 1/m (positive turning left). Shared by the simulator's tracks and open to
the planner's baseframe.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from common.conventions import wrap_angles

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]


def segments(poly_xy: FloatArray, closed: bool) -> tuple[FloatArray, FloatArray]:
    """Segment start points (K, 2) and vectors (K, 2) of a polyline."""
    if closed:
        return poly_xy, np.roll(poly_xy, -1, axis=0) - poly_xy
    return poly_xy[:-1], poly_xy[1:] - poly_xy[:-1]


def nearest_on_polyline(
    points_xy: FloatArray, poly_xy: FloatArray, closed: bool
) -> tuple[FloatArray, IntArray, FloatArray, FloatArray]:
    """Nearest point on a polyline for each of ``points_xy`` (P, 2).

    Returns ``(distance_m (P,), segment_index (P,), t (P,) in [0, 1] along that segment,
    projection_xy (P, 2))``.
    """
    a, ab = segments(poly_xy, closed)
    p = np.asarray(points_xy, np.float64).reshape(-1, 2)
    ab2 = np.maximum((ab * ab).sum(axis=1), 1e-12)
    rel_x = p[:, None, 0] - a[None, :, 0]
    rel_y = p[:, None, 1] - a[None, :, 1]
    t = np.clip((rel_x * ab[None, :, 0] + rel_y * ab[None, :, 1]) / ab2[None, :], 0.0, 1.0)
    dx = rel_x - t * ab[None, :, 0]
    dy = rel_y - t * ab[None, :, 1]
    d2 = dx * dx + dy * dy
    idx = np.argmin(d2, axis=1)
    rows = np.arange(p.shape[0])
    tt = t[rows, idx]
    proj = a[idx] + tt[:, None] * ab[idx]
    return np.sqrt(d2[rows, idx]), idx.astype(np.int64), tt, proj


def side_of(points_xy: FloatArray, poly_xy: FloatArray,
            closed: bool) -> tuple[FloatArray, FloatArray]:
    """Signed lateral offset (m, positive left of the direction of travel) (P,) and progress
    along the polyline (m) (P,) of each of ``points_xy`` (P, 2)."""
    a, ab = segments(poly_xy, closed)
    d, seg, t, _ = nearest_on_polyline(points_xy, poly_xy, closed)
    seg_len = np.hypot(ab[:, 0], ab[:, 1])
    s = np.concatenate([[0.0], np.cumsum(seg_len)])[seg] + t * seg_len[seg]
    rel = points_xy - a[seg]
    cross = ab[seg, 0] * rel[:, 1] - ab[seg, 1] * rel[:, 0]
    return np.where(cross >= 0.0, d, -d), s


def arc_lengths(poly_xy: FloatArray) -> FloatArray:
    """Cumulative arc length (m) at each vertex (K,), starting at 0, along the open polyline
    (append the first vertex to include a closing segment)."""
    d = np.hypot(*np.diff(poly_xy, axis=0).T)
    return np.concatenate([[0.0], np.cumsum(d)])


def polyline_length(poly_xy: FloatArray, closed: bool) -> float:
    """Total length (m) of a polyline (closing segment included when ``closed``)."""
    d = float(np.hypot(*np.diff(poly_xy, axis=0).T).sum())
    if closed and len(poly_xy) > 1:
        d += float(np.hypot(*(poly_xy[0] - poly_xy[-1])))
    return d


def resample(poly_xy: FloatArray, step_m: float, closed: bool) -> FloatArray:
    """Resample a polyline linearly at (about) equal arc-length steps of ``step_m``; a closed
    one stays implicitly closed."""
    pts = np.vstack([poly_xy, poly_xy[:1]]) if closed else poly_xy
    s = arc_lengths(pts)
    total = float(s[-1])
    if total <= 0.0:
        return poly_xy.copy()
    n = max(int(round(total / step_m)), 2)
    if closed:
        q = np.linspace(0.0, total, n, endpoint=False)
    else:
        q = np.linspace(0.0, total, n + 1)
    return np.stack([np.interp(q, s, pts[:, 0]), np.interp(q, s, pts[:, 1])], axis=1)


def smooth_closed(poly_xy: FloatArray, window: int) -> FloatArray:
    """Periodic moving average of a closed polyline (N, 2) over an odd ``window`` (samples)."""
    if window <= 1 or len(poly_xy) < window:
        return poly_xy.copy()
    half = window // 2
    padded = np.vstack([poly_xy[-half:], poly_xy, poly_xy[:half]])
    kernel = np.ones(window) / window
    return np.stack([np.convolve(padded[:, k], kernel, mode="valid") for k in (0, 1)], axis=1)


def polyline_curvature(poly_xy: FloatArray, closed: bool) -> FloatArray:
    """Signed curvature (1/m, positive turning left) at each vertex (K,) from heading changes."""
    pts = np.vstack([poly_xy[-1:], poly_xy, poly_xy[:1]]) if closed else poly_xy
    seg = np.diff(pts, axis=0)
    heading = np.arctan2(seg[:, 1], seg[:, 0])
    length = np.hypot(seg[:, 0], seg[:, 1])
    dh = wrap_angles(np.diff(heading))
    ds = 0.5 * (length[1:] + length[:-1])
    k = dh / np.maximum(ds, 1e-9)
    if closed:
        return k
    return np.concatenate([[k[0] if len(k) else 0.0], k, [k[-1] if len(k) else 0.0]])


def headings(poly_xy: FloatArray, closed: bool) -> FloatArray:
    """Heading (rad) of the segment leaving each vertex (K,); an open polyline's last vertex
    keeps its incoming heading."""
    if closed:
        nxt = np.roll(poly_xy, -1, axis=0)
    else:
        nxt = np.vstack([poly_xy[1:], 2 * poly_xy[-1:] - poly_xy[-2:-1]])
    d = nxt - poly_xy
    return np.arctan2(d[:, 1], d[:, 0])


def to_pose_frame(xy: FloatArray, pose: tuple[float, float, float]) -> FloatArray:
    """Points (N, 2) into the frame of ``pose`` (x, y, yaw) given in the points' frame."""
    x0, y0, yaw0 = pose
    c, s = math.cos(yaw0), math.sin(yaw0)
    d = np.asarray(xy, np.float64).reshape(-1, 2) - np.array([x0, y0])
    return np.stack([d[:, 0] * c + d[:, 1] * s, -d[:, 0] * s + d[:, 1] * c], axis=1)
