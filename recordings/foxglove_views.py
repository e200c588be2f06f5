"""Foxglove views of the stack's messages: ``foxglove.SceneUpdate``, ``foxglove.FrameTransform``
and ``foxglove.LocationFix``.

The recorder writes these next to the stack's own topics so that a recording opens in Foxglove's
3D and Map panels with no setup. Everything is drawn in the ``world`` frame (the car's start
pose); cones are truncated cones of their class's size and colour, the car a box with an arrow
along its heading and its 2-sigma position ellipse, the plan the baseframe, the candidate
manoeuvres (thin) and the chosen one, the driven trace a line in segments (:class:`TraceSegments`).
"""

from __future__ import annotations

import math
from collections.abc import Iterable

import numpy as np
from google.protobuf.duration_pb2 import Duration
from google.protobuf.timestamp_pb2 import Timestamp

from common.messages import ConeColour, ConeSize, GpsFix, MapState, Plan, PoseEstimate
from common.track import TrackLayout
from recordings.foxglove import schemas as fg

WORLD_FRAME = "world"
CAR_FRAME = "base_link"
GPS_FRAME = "gps"

#: RGBA of each cone colour class.
CONE_RGBA: dict[int, tuple[float, float, float, float]] = {
    int(ConeColour.UNKNOWN): (0.6, 0.6, 0.6, 1.0),
    int(ConeColour.BLUE): (0.1, 0.3, 1.0, 1.0),
    int(ConeColour.YELLOW): (1.0, 0.85, 0.0, 1.0),
    int(ConeColour.ORANGE): (1.0, 0.5, 0.0, 1.0),
    int(ConeColour.BIG_ORANGE): (1.0, 0.35, 0.0, 1.0),
}

#: (base diameter m, height m) of each cone size class (Formula Student rules).
CONE_DIMENSIONS_M: dict[int, tuple[float, float]] = {
    int(ConeSize.UNKNOWN): (0.228, 0.325),
    int(ConeSize.SMALL): (0.228, 0.325),
    int(ConeSize.LARGE): (0.285, 0.505),
}

CAR_RGBA = (0.85, 0.1, 0.1, 0.8)
ELLIPSE_RGBA = (1.0, 1.0, 1.0, 0.9)
TRACE_RGBA = (0.95, 0.3, 0.35, 1.0)
CANDIDATE_RGBA = (0.55, 0.55, 0.7, 0.6)
PLAN_RGBA = (0.1, 0.9, 0.3, 1.0)
BASEFRAME_RGBA = (0.9, 0.9, 0.9, 0.6)
TRUTH_RGBA_ALPHA = 0.35


def timestamp(t_s: float) -> Timestamp:
    """A protobuf Timestamp for ``t_s`` seconds on the run's clock (nanosecond rounding)."""
    ns = round(t_s * 1e9)
    return Timestamp(seconds=ns // 1_000_000_000, nanos=ns % 1_000_000_000)


def _color(rgba: tuple[float, float, float, float], alpha: float | None = None) -> fg.Color:
    r, g, b, a = rgba
    return fg.Color(r=r, g=g, b=b, a=a if alpha is None else alpha)


def _pose(x_m: float, y_m: float, z_m: float = 0.0, yaw_rad: float = 0.0) -> fg.Pose:
    half_yaw = 0.5 * yaw_rad
    return fg.Pose(
        position=fg.Vector3(x=x_m, y=y_m, z=z_m),
        orientation=fg.Quaternion(x=0.0, y=0.0, z=math.sin(half_yaw), w=math.cos(half_yaw)),
    )


def _cone(x_m: float, y_m: float, colour: int, size: int,
          alpha: float | None = None) -> fg.CylinderPrimitive:
    diameter_m, height_m = CONE_DIMENSIONS_M.get(int(size), CONE_DIMENSIONS_M[0])
    return fg.CylinderPrimitive(
        pose=_pose(x_m, y_m, 0.5 * height_m),
        size=fg.Vector3(x=diameter_m, y=diameter_m, z=height_m),
        bottom_scale=1.0,
        top_scale=0.15,
        color=_color(CONE_RGBA.get(int(colour), CONE_RGBA[0]), alpha),
    )


def _cones(
    xy_m: np.ndarray, colours: Iterable[int], sizes: Iterable[int], alpha: float | None = None
) -> list[fg.CylinderPrimitive]:
    return [_cone(x, y, colour, size, alpha)
            for (x, y), colour, size in zip(xy_m.tolist(), colours, sizes, strict=True)]


class ConeDrawer:
    """The cones of map states as cylinder primitives, each made once per (position to the
    millimetre, colour, size) and reused: a map's cones barely move from one map state to the
    next, and making them was most of a map scene's cost (about 1 ms for 100 cones, against
    0.1 ms reused). Cones are drawn at their position rounded to the millimetre. At most
    ``limit`` primitives are kept (all dropped when full). For one thread."""

    def __init__(self, limit: int = 20000) -> None:
        self.limit = limit
        self._made: dict[tuple[int, int, int, int], fg.CylinderPrimitive] = {}

    def __call__(self, xy_m: np.ndarray, colours: Iterable[int],
                 sizes: Iterable[int]) -> list[fg.CylinderPrimitive]:
        """Primitives of cones at ``xy_m`` (N, 2) (m) with their colour and size classes."""
        if len(self._made) > self.limit:
            self._made.clear()
        mm = np.rint(np.asarray(xy_m, dtype=np.float64).reshape(-1, 2) * 1000.0)
        out = []
        for (x, y), colour, size in zip(mm.astype(np.int64).tolist(), colours, sizes,
                                        strict=True):
            key = (x, y, int(colour), int(size))
            cone = self._made.get(key)
            if cone is None:
                cone = self._made[key] = _cone(x * 1e-3, y * 1e-3, colour, size)
            out.append(cone)
        return out


def _line(
    xy_m: np.ndarray, rgba: tuple[float, float, float, float], thickness_m: float, loop: bool
) -> fg.LinePrimitive:
    return fg.LinePrimitive(
        type=fg.LinePrimitive.LINE_LOOP if loop else fg.LinePrimitive.LINE_STRIP,
        pose=_pose(0.0, 0.0),
        thickness=thickness_m,
        scale_invariant=False,
        points=[fg.Point3(x=x, y=y, z=0.02) for x, y in xy_m.tolist()],
        color=_color(rgba),
    )


def map_scene(
    state: MapState,
    car_length_m: float = 2.9,
    car_width_m: float = 1.4,
    rear_overhang_m: float = 0.65,
    drawer: ConeDrawer | None = None,
) -> fg.SceneUpdate:
    """Cones (entity ``cones``) and the estimated car (entity ``car``) of one map state;
    ``drawer`` (one per stream of map states) reuses the cones drawn before."""
    stamp = timestamp(state.timestamp_s)
    cones = state.cones
    draw = drawer if drawer is not None else _cones
    cone_entity = fg.SceneEntity(
        timestamp=stamp,
        frame_id=WORLD_FRAME,
        id="cones",
        lifetime=Duration(),
        cylinders=draw(cones.xy_m, cones.colour.tolist(), cones.size.tolist()),
        metadata=[
            fg.KeyValuePair(key="count", value=str(len(cones))),
            fg.KeyValuePair(key="loop_closed", value=str(state.loop_closed).lower()),
            fg.KeyValuePair(key="backend", value=state.backend),
        ],
    )
    pose = state.pose
    c, s = math.cos(pose.yaw_rad), math.sin(pose.yaw_rad)
    centre_ahead_m = 0.5 * car_length_m - rear_overhang_m  # box centre ahead of the rear axle
    car_entity = fg.SceneEntity(
        timestamp=stamp,
        frame_id=WORLD_FRAME,
        id="car",
        lifetime=Duration(),
        cubes=[
            fg.CubePrimitive(
                pose=_pose(pose.x_m + centre_ahead_m * c, pose.y_m + centre_ahead_m * s, 0.3,
                           pose.yaw_rad),
                size=fg.Vector3(x=car_length_m, y=car_width_m, z=0.6),
                color=_color(CAR_RGBA),
            )
        ],
        arrows=[
            fg.ArrowPrimitive(
                pose=_pose(pose.x_m, pose.y_m, 0.7, pose.yaw_rad),
                shaft_length=max(1.0, 0.5 * pose.speed_mps),
                shaft_diameter=0.1,
                head_length=0.4,
                head_diameter=0.3,
                color=_color(CAR_RGBA, 1.0),
            )
        ],
        lines=[_line(pose_ellipse_xy_m(pose.x_m, pose.y_m, pose.covariance[:2, :2]),
                     ELLIPSE_RGBA, 0.04, True)],
        metadata=[fg.KeyValuePair(key="speed_mps", value=f"{pose.speed_mps:.3f}")],
    )
    return fg.SceneUpdate(entities=[cone_entity, car_entity])


def pose_ellipse_xy_m(x_m: float, y_m: float, cov_xy: np.ndarray, n_sigma: float = 2.0,
                      steps: int = 24) -> np.ndarray:
    """Outline (steps, 2) of the ``n_sigma`` ellipse of a 2x2 position covariance (m^2)."""
    sym = 0.5 * (np.asarray(cov_xy, dtype=float) + np.asarray(cov_xy, dtype=float).T)
    if not np.all(np.isfinite(sym)):
        sym = np.zeros((2, 2))
    values, vectors = np.linalg.eigh(sym)
    radii = n_sigma * np.sqrt(np.clip(values, 0.0, None))
    angles = np.linspace(0.0, 2.0 * math.pi, steps, endpoint=False)
    local = np.stack([np.cos(angles) * radii[0], np.sin(angles) * radii[1]], axis=1)
    return local @ vectors.T + np.array([x_m, y_m])


class TraceSegments:
    """The driven trace as a scene: each ``period_s`` of log time, the estimated poses since the
    last segment become one more entity (``trace/<n>``, kept for good), so every message stays
    small however long the run."""

    def __init__(self, period_s: float = 1.0) -> None:
        self.period_s = period_s
        self._points: list[tuple[float, float]] = []
        self._start_s: float | None = None
        self._count = 0

    def add(self, t_s: float, x_m: float, y_m: float) -> fg.SceneUpdate | None:
        """Add a pose at ``t_s``; returns a scene update when a segment is complete."""
        self._points.append((x_m, y_m))
        if self._start_s is None:
            self._start_s = t_s
        if t_s - self._start_s < self.period_s - 1e-9 or len(self._points) < 2:
            return None
        entity = fg.SceneEntity(
            timestamp=timestamp(t_s), frame_id=WORLD_FRAME, id=f"trace/{self._count:06d}",
            lifetime=Duration(),
            lines=[_line(np.asarray(self._points), TRACE_RGBA, 0.08, False)],
        )
        self._count += 1
        self._points = self._points[-1:]  # the next segment starts where this one ends
        self._start_s = t_s
        return fg.SceneUpdate(entities=[entity])


class LineMemo:
    """The last line drawn, reused while its points and style are the same: a plan's
    baseframe, redrawn with every plan (10 Hz) and unchanged once the race line is fixed
    (1,140 points on the default track; drawing it was most of a plan scene's cost)."""

    def __init__(self) -> None:
        self._key: tuple[np.ndarray, np.ndarray, tuple[float, float, float, float], float,
                         bool] | None = None
        self._line: fg.LinePrimitive | None = None

    def __call__(self, x_m: np.ndarray, y_m: np.ndarray, rgba: tuple[float, float, float, float],
                 thickness_m: float, loop: bool) -> fg.LinePrimitive:
        """The line through ``x_m``, ``y_m`` (N,) each (m)."""
        x, y = np.asarray(x_m, dtype=np.float64), np.asarray(y_m, dtype=np.float64)
        key = self._key
        if (self._line is not None and key is not None and key[2:] == (rgba, thickness_m, loop)
                and np.array_equal(key[0], x) and np.array_equal(key[1], y)):
            return self._line
        self._line = _line(np.column_stack([x, y]), rgba, thickness_m, loop)
        self._key = (x.copy(), y.copy(), rgba, thickness_m, loop)
        return self._line


def plan_scene(plan: Plan, candidates: bool = True,
               baseframe_memo: LineMemo | None = None) -> fg.SceneUpdate:
    """The chosen manoeuvre and the baseframe of a plan (entity ``plan``);
    ``baseframe_memo`` (one per stream of plans) reuses the baseframe drawn last."""
    lines = []
    if plan.baseframe is not None and len(plan.baseframe.x_m) > 1:
        bf = plan.baseframe
        draw = baseframe_memo if baseframe_memo is not None else LineMemo()
        lines.append(draw(bf.x_m, bf.y_m, BASEFRAME_RGBA, 0.05, bf.closed))
    for index, candidate in enumerate(plan.candidates if candidates else ()):
        if index != plan.chosen_index and len(candidate) > 1:
            lines.append(_line(np.asarray(candidate), CANDIDATE_RGBA, 0.03, False))
    if len(plan.manoeuvre) > 1:
        m = plan.manoeuvre
        lines.append(_line(np.column_stack([m.x_m, m.y_m]), PLAN_RGBA, 0.15, False))
    entity = fg.SceneEntity(
        timestamp=timestamp(plan.timestamp_s),
        frame_id=WORLD_FRAME,
        id="plan",
        lifetime=Duration(),
        lines=lines,
        metadata=[fg.KeyValuePair(key="target_speed_mps", value=f"{plan.target_speed_mps:.3f}")],
    )
    return fg.SceneUpdate(entities=[entity])


def track_scene(track: TrackLayout, t_s: float) -> fg.SceneUpdate:
    """The true cones and centreline of a simulated track, faint (entity ``truth_track``)."""
    cones_xy = np.asarray(track.cones_xy_m, dtype=np.float64).reshape(-1, 2)
    centreline = np.asarray(track.centreline_xy_m, dtype=np.float64).reshape(-1, 2)
    entity = fg.SceneEntity(
        timestamp=timestamp(t_s),
        frame_id=WORLD_FRAME,
        id="truth_track",
        lifetime=Duration(),
        cylinders=_cones(
            cones_xy,
            np.asarray(track.colours).tolist(),
            np.asarray(track.sizes).tolist(),
            alpha=TRUTH_RGBA_ALPHA,
        ),
        lines=[_line(centreline, BASEFRAME_RGBA, 0.03, bool(track.is_loop))]
        if len(centreline) > 1
        else [],
        metadata=[fg.KeyValuePair(key="name", value=str(track.name))],
    )
    return fg.SceneUpdate(entities=[entity])


def frame_transform(pose: PoseEstimate) -> fg.FrameTransform:
    """The estimated car (``base_link``, rear axle) in ``world``: a 3D panel can follow it."""
    half_yaw = 0.5 * pose.yaw_rad
    return fg.FrameTransform(
        timestamp=timestamp(pose.timestamp_s),
        parent_frame_id=WORLD_FRAME,
        child_frame_id=CAR_FRAME,
        translation=fg.Vector3(x=pose.x_m, y=pose.y_m, z=0.0),
        rotation=fg.Quaternion(x=0.0, y=0.0, z=math.sin(half_yaw), w=math.cos(half_yaw)),
    )


#: Assumed user-equivalent range error (m) turning HDOP into a horizontal sigma.
UERE_M = 2.5


def location_fix(fix: GpsFix) -> fg.LocationFix:
    """A ``foxglove.LocationFix`` for a GNSS fix (covariance approximated from HDOP)."""
    message = fg.LocationFix(
        frame_id=GPS_FRAME,
        timestamp=timestamp(fix.timestamp_s),
        latitude=fix.lat_deg,
        longitude=fix.lon_deg,
        altitude=fix.altitude_m if math.isfinite(fix.altitude_m) else 0.0,
    )
    if math.isfinite(fix.hdop) and fix.hdop > 0.0:
        var_h = (fix.hdop * UERE_M) ** 2
        message.position_covariance.extend([var_h, 0, 0, 0, var_h, 0, 0, 0, 4.0 * var_h])
        message.position_covariance_type = fg.LocationFix.APPROXIMATED
    return message
