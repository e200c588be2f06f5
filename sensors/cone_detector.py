"""LiDAR cone detection in one VLP-16 sweep (seed 000, section 4.2), vectorised with numpy.

Steps, each a few array operations over the sweep:

1. Usable field of view: returns too near, too far, behind the usable azimuth range or inside
   the car's footprint are dropped (they are the car itself, seed 000 fig 4.1).
2. Ground removal: with the sensor ``car.lidar_z_m`` above a flat ground, returns lower than
   ``ground_clearance_m`` above it are ground; returns higher than ``max_point_height_m``
   cannot be a cone. Only the rest can be cone surfaces.
3. Surfaces: along each laser ring, in azimuth order, runs of successive returns whose range
   differs little; a range discontinuity (or an azimuth gap) starts a new surface.
4. Preliminary filter: a surface narrower than a cone, nearer than ``max_range_m``, of more
   than one return.
5. Surfaces whose x-y midpoints are close are merged into preliminary cones.
6. Cluster filter: a preliminary cone with more than ``cluster_max_cones`` within
   ``cluster_radius_m`` (grass, bushes, barriers) is removed with its neighbours.
7. Final filter: seen in at least ``min_layers`` rings, at least ``min_points`` returns, top
   below ``large_height_m`` (+ tolerance). Size: a top above ``small_height_m`` means large
   (the seed's rule); a lower top is compared with what each cone size would show on each ring
   at that range, because with 2 deg between rings the top of a large cone beyond ~7 m falls
   between two rings. For the same reason a small cone beyond ~5.7 m (mount 0.3 m) is hit by
   one ring only: a single layer is accepted when no second ring can reach it.

Position: the LiDAR sees the near half of the cone, so the centroid of the returns is pushed
back along the line of sight by pi/4 times the cone's radius at each return's height (the mean
depth of a half circle sampled evenly across its width). Each cone is stamped with the mean time
of its returns (a sweep takes 100 ms) and given in the VEHICLE frame: the sensor frame shifted
by ``car.lidar_x_m`` forward and ``car.lidar_z_m`` up.
"""

from __future__ import annotations

import logging
import math

import numpy as np
from numpy.typing import NDArray

from common.car import CarConfig
from common.messages import ConeColour, ConeDetection, ConeSize, LidarCones
from sensors.config import DetectorConfig
from sensors.ground import GroundSurface, fit_ground, flat_ground
from sensors.lidar_models import LIDAR_MODELS, LidarModel, rings_from_elevation
from sensors.velodyne import ReturnWindow

log = logging.getLogger(__name__)

SMALL_CONE_BASE_M = 0.228
SMALL_CONE_HEIGHT_M = 0.325
LARGE_CONE_BASE_M = 0.285
LARGE_CONE_HEIGHT_M = 0.505
GROUND_MODELS = ("flat", "estimated")


def cone_radius_m(size: ConeSize, height_m: NDArray[np.float64]) -> NDArray[np.float64]:
    """Radius (m) of a cone of ``size`` at ``height_m`` above the ground (0 above its top)."""
    if size == ConeSize.LARGE:
        base, top = LARGE_CONE_BASE_M, LARGE_CONE_HEIGHT_M
    else:
        base, top = SMALL_CONE_BASE_M, SMALL_CONE_HEIGHT_M
    return 0.5 * base * np.clip(1.0 - height_m / top, 0.0, 1.0)


class ConeDetector:
    """Cones in one sweep of points; see the module docstring for the steps."""

    def __init__(self, config: DetectorConfig, car: CarConfig,
                 model: LidarModel | None = None) -> None:
        if config.ground not in GROUND_MODELS:
            raise ValueError(f"sensors.lidar.detector.ground: {config.ground!r} is not one of "
                             f"{', '.join(GROUND_MODELS)}")
        self.cfg = config
        self.car = car
        self.model = model if model is not None else LIDAR_MODELS["vlp16"]
        self._tan_ring = np.tan(np.radians(self.model.ring_elevation_deg))
        self._n_rings = self.model.beams
        self.lidar_x_m = car.lidar_x_m
        self.lidar_z_m = car.lidar_z_m
        self.stats: dict[str, int] = {}
        """Counts of the last call: points kept at each step, surfaces, preliminary cones."""
        self.ground = flat_ground(car.lidar_z_m)
        """The ground of the last sweep (the configured plane with ``ground = "flat"``)."""

    def return_window(self) -> ReturnWindow:
        """The returns that can pass this detector's first filters (height above the ground,
        horizontal range), with a margin: decoding only those gives the same cones, faster
        (the car's own body and the ground are most of a sweep)."""
        cfg = self.cfg
        margin_m = 1e-6
        if cfg.ground == "estimated":  # the ground's returns are what the ground is fitted to
            return ReturnWindow(min_range_m=max(cfg.min_range_m - margin_m, 0.0),
                                max_range_m=cfg.max_range_m + 1.0 + margin_m,
                                z_min_m=-math.inf, z_max_m=math.inf)
        return ReturnWindow(
            min_range_m=max(cfg.min_range_m - margin_m, 0.0),
            max_range_m=cfg.max_range_m + 1.0 + margin_m,
            z_min_m=cfg.ground_clearance_m - self.lidar_z_m - margin_m,
            z_max_m=cfg.max_point_height_m - self.lidar_z_m + margin_m,
        )

    def detect(self, points: NDArray[np.float64], rings: NDArray[np.int64] | None,
               times_s: NDArray[np.float64], timestamp_s: float,
               point_count: int = 0, start_s: float = math.nan) -> LidarCones:
        """Detect cones in one sweep.

        ``points`` (N, >=3): x, y, z (m, sensor frame)[, intensity]; ``rings`` (N,) the beam
        of each return numbered by elevation (0 = lowest), or None to find it from each
        return's elevation with the sensor model's table; ``times_s`` (N,) each return's time;
        ``timestamp_s`` the sweep's end;
        ``point_count`` the sweep's returns when ``points`` are only those inside
        :meth:`return_window` (0: N) and ``start_s`` the time of its first return (nan: the
        earliest of ``times_s``). Returns cones in the vehicle frame, each stamped with the
        time it was seen.
        """
        cfg = self.cfg
        n_all = int(point_count) or int(points.shape[0])
        if math.isnan(start_s):
            start_s = float(times_s.min()) if times_s.size else math.nan
        sweep_start = start_s
        if cfg.ground == "estimated":
            # the ground is fitted to, and cones looked for in, the returns within reach
            reach = self._within_reach(points)
            points, times_s = points[reach], times_s[reach]
            rings = rings[reach] if rings is not None else None
            self.ground = self._fit_ground(points)
            z_ground = points[:, 2] - self.ground.height_m(points[:, 0], points[:, 1])
        else:
            z_ground = points[:, 2] + self.lidar_z_m
        keep = (z_ground > cfg.ground_clearance_m) & (z_ground < cfg.max_point_height_m)
        idx = np.flatnonzero(keep)
        x = points[idx, 0]
        y = points[idx, 1]
        # Most non-ground returns are the car itself, within min_range_m: drop them (and those
        # far out) on the squared range first, with a margin so that the exact tests below
        # decide alone; the costly hypot and arctan2 then run on the few left.
        r2 = x * x + y * y
        near = (r2 > cfg.min_range_m**2 * (1.0 - 1e-9)) & (
            r2 < (cfg.max_range_m + 1.0) ** 2 * (1.0 + 1e-9))
        idx, x, y = idx[near], x[near], y[near]
        r = np.hypot(x, y)
        bearing = np.arctan2(y, x)
        xv = x + self.lidar_x_m
        half_w = 0.5 * self.car.width_m + cfg.car_margin_m
        on_car = ((xv > -self.car.rear_overhang_m - cfg.car_margin_m)
                  & (xv < self.car.length_m - self.car.rear_overhang_m + cfg.car_margin_m)
                  & (np.abs(y) < half_w))
        ok = ((r > cfg.min_range_m) & (r < cfg.max_range_m + 1.0)
              & (np.abs(bearing) < math.radians(cfg.fov_half_deg)) & ~on_car)
        idx = idx[ok]
        self.stats = {"points": n_all, "non_ground": int(keep.sum()), "usable": int(idx.size)}
        if idx.size < cfg.min_points:
            return LidarCones(timestamp_s, (), sweep_start, n_all)
        x, y, r, bearing = x[ok], y[ok], r[ok], bearing[ok]
        z = z_ground[idx]
        # a cloud saved without ring numbers: each return's ring from its elevation
        ring = rings[idx] if rings is not None else rings_from_elevation(points[idx], self.model)
        t = times_s[idx]

        # --- surfaces: runs along each ring in azimuth order, split at range discontinuities
        order = np.lexsort((-bearing, ring))
        x, y, z, r, bearing, ring, t = (a[order] for a in (x, y, z, r, bearing, ring, t))
        d_bearing = np.abs(np.diff(bearing))
        brk = np.empty(x.size, dtype=bool)
        brk[0] = True
        brk[1:] = ((ring[1:] != ring[:-1]) | (np.abs(np.diff(r)) > cfg.surface_range_jump_m)
                   | (d_bearing > math.radians(cfg.surface_max_gap_deg)))
        starts = np.flatnonzero(brk)
        seg = np.cumsum(brk) - 1
        n_seg = starts.size
        count = np.diff(np.append(starts, x.size))
        ends = starts + count - 1
        sx = np.bincount(seg, x, n_seg) / count
        sy = np.bincount(seg, y, n_seg) / count
        sr = np.hypot(sx, sy)
        width = np.hypot(x[ends] - x[starts], y[ends] - y[starts])
        step = d_bearing[~brk[1:]]
        az_step = float(np.median(step)) if step.size else math.radians(0.2)
        az_step = max(az_step, math.radians(0.05))
        # each return stands for one azimuth step of surface: add one step to the chord
        width = width + sr * az_step
        good = ((count >= max(cfg.min_surface_points, 1)) & (width < cfg.max_surface_width_m)
                & (sr < cfg.max_range_m))
        self.stats["surfaces"] = int(n_seg)
        self.stats["surfaces_kept"] = int(good.sum())
        if not good.any():
            return LidarCones(timestamp_s, (), sweep_start, n_all)
        surf = np.flatnonzero(good)

        # --- merge surfaces with close x-y midpoints into preliminary cones
        label = _components(sx[surf], sy[surf], cfg.merge_distance_m)
        n_cones = int(label.max()) + 1
        pt_surf_ok = good[seg]
        seg_to_cone = np.full(n_seg, -1, dtype=np.int64)
        seg_to_cone[surf] = label
        pc = seg_to_cone[seg]  # preliminary cone of each return, -1 if none
        m = pt_surf_ok
        px, py, pz, pring, pt, pcone = x[m], y[m], z[m], ring[m], t[m], pc[m]
        npts = np.bincount(pcone, minlength=n_cones)
        cx = np.bincount(pcone, px, n_cones) / npts
        cy = np.bincount(pcone, py, n_cones) / npts

        # --- cluster filter
        clustered = _clustered(cx, cy, cfg.cluster_radius_m, cfg.cluster_max_cones)
        self.stats["preliminary"] = n_cones
        self.stats["clustered"] = int(clustered.sum())

        # --- final filter
        ring_hits = np.zeros((n_cones, self._n_rings), dtype=np.int64)
        np.add.at(ring_hits, (pcone, pring), 1)
        layers = (ring_hits > 0).sum(axis=1)
        top = np.full(n_cones, -np.inf)
        np.maximum.at(top, pcone, pz)
        rng = np.hypot(cx, cy)
        exp_small = self._expected_hits(rng, ConeSize.SMALL, az_step)
        exp_large = self._expected_hits(rng, ConeSize.LARGE, az_step)
        # one layer is enough where a small cone cannot show on more rings at that range
        reachable_small = (exp_small >= 2.0).sum(axis=1)
        layer_ok = (layers >= cfg.min_layers) | (
            (layers >= 1) & (rng > cfg.single_layer_beyond_m)
            & (reachable_small < cfg.min_layers))
        if cfg.min_layer_fraction > 0.0:  # a dense sensor hits a real cone on most rings
            crossing = (exp_small > 0.0).sum(axis=1)
            layer_ok &= layers >= np.floor(cfg.min_layer_fraction * crossing)
        height_ok = (top < cfg.large_height_m + cfg.height_tolerance_m) & (top >= cfg.min_top_m)
        if cfg.max_float_m > 0.0:  # a cone stands on the ground: its lowest return is low
            bottom = np.full(n_cones, np.inf)
            np.minimum.at(bottom, pcone, pz)
            height_ok &= bottom <= self._lowest_ring_height(rng) + cfg.max_float_m
        final = ~clustered & layer_ok & (npts >= cfg.min_points) & height_ok
        # the neighbourhood checks, on the few candidates left
        if cfg.tall_clearance_m > 0.0 and final.any():
            left = np.flatnonzero(final)
            final[left[self._near_tall(points, z_ground, cx[left], cy[left])]] = False
        if cfg.clear_outer_m > 0.0 and final.any():
            left = np.flatnonzero(final)
            final[left[self._cluttered(points, z_ground, cx[left], cy[left])]] = False
        # size: a top above small_height_m is a large cone; else compare per-ring counts
        err_small = (((ring_hits - exp_small) ** 2) / (exp_small + 1.0)).sum(axis=1)
        err_large = (((ring_hits - exp_large) ** 2) / (exp_large + 1.0)).sum(axis=1)
        large = top >= cfg.small_height_m
        if cfg.size_from_ring_counts:
            large |= err_large < err_small
        self.stats["cones"] = int(final.sum())

        cones: list[ConeDetection] = []
        if not final.any():
            return LidarCones(timestamp_s, (), sweep_start, n_all)
        # centre: push the centroid back along the line of sight by pi/4 of the radius
        pt_large = large[pcone]
        radius = np.where(pt_large, cone_radius_m(ConeSize.LARGE, pz),
                          cone_radius_m(ConeSize.SMALL, pz))
        push = (np.bincount(pcone, radius, n_cones) / npts
                * (math.pi / 4.0 * cfg.centre_push_fraction))
        ux, uy = cx / np.maximum(rng, 1e-9), cy / np.maximum(rng, 1e-9)
        centre_x = cx + ux * push + self.lidar_x_m
        centre_y = cy + uy * push
        t_seen = np.bincount(pcone, pt, n_cones) / npts
        surf_cone = label
        max_width = np.zeros(n_cones)
        np.maximum.at(max_width, surf_cone, width[surf])
        for i in np.flatnonzero(final):
            cones.append(ConeDetection(
                timestamp_s=float(t_seen[i]),
                x_m=float(centre_x[i]),
                y_m=float(centre_y[i]),
                colour=ConeColour.UNKNOWN,
                size=ConeSize.LARGE if large[i] else ConeSize.SMALL,
                confidence=1.0,
                height_m=float(top[i]),
                width_m=float(max_width[i]),
            ))
        return LidarCones(timestamp_s, tuple(cones), sweep_start, n_all)

    def _within_reach(self, points: NDArray[np.float64]) -> NDArray[np.bool_]:
        """The returns (N,) that can be ground under a cone or a tall neighbour of one: within
        the detector's range, with a margin of ``tall_clearance_m`` and one ground cell."""
        cfg = self.cfg
        x, y = points[:, 0], points[:, 1]
        r2 = x * x + y * y
        far_m = cfg.max_range_m + 1.0 + max(cfg.tall_clearance_m, cfg.ground_cell_m)
        return (r2 > (cfg.min_range_m - cfg.ground_cell_m) ** 2) & (r2 < far_m * far_m)

    def _fit_ground(self, points: NDArray[np.float64]) -> GroundSurface:
        """The ground of this sweep, from its returns within reach."""
        cfg = self.cfg
        return fit_ground(points[:, 0], points[:, 1], points[:, 2], cfg.ground_cell_m,
                          cfg.ground_max_residual_m, self.lidar_z_m)

    def _near_tall(self, points: NDArray[np.float64], z_ground: NDArray[np.float64],
                   cx: NDArray[np.float64], cy: NDArray[np.float64]) -> NDArray[np.bool_]:
        """Which preliminary cones (K,) have returns too high for a cone (a leg, a pole, a
        barrier; more than ``clear_max_returns``, so that a few raindrops do not count) within
        ``tall_clearance_m`` of their centre (``cx``, ``cy``, sensor frame)."""
        cfg = self.cfg
        tall = ((z_ground >= cfg.max_point_height_m)
                & (z_ground < cfg.max_point_height_m + 2.0))
        counts, _ = _ring_stats(points[tall, 0], points[tall, 1], z_ground[tall], cx, cy, 0.0,
                                cfg.tall_clearance_m)
        return counts > cfg.clear_max_returns

    def _cluttered(self, points: NDArray[np.float64], z_ground: NDArray[np.float64],
                   cx: NDArray[np.float64], cy: NDArray[np.float64]) -> NDArray[np.bool_]:
        """Which preliminary cones (K,) do not stand on open ground, judged by the returns in
        the ring ``clear_inner_m`` .. ``clear_outer_m`` round them: more than
        ``clear_max_returns`` above the ground (a bush, a kerb, a wall's foot), or none lower
        than ``ground_max_residual_m`` above the fitted ground (the ground there is not where
        the fit puts it, an embankment, so the candidate's height means nothing)."""
        cfg = self.cfg
        below = z_ground < cfg.max_point_height_m
        counts, lowest = _ring_stats(points[below, 0], points[below, 1], z_ground[below], cx, cy,
                                     cfg.clear_inner_m, cfg.clear_outer_m,
                                     above_m=cfg.ground_clearance_m)
        return (counts > cfg.clear_max_returns) | (lowest > cfg.ground_max_residual_m)

    def _lowest_ring_height(self, rng: NDArray[np.float64]) -> NDArray[np.float64]:
        """Height (K,) above the ground of the lowest ring that passes over the ground
        clearance at each range ``rng`` (K,) (m): where a cone's lowest return can be."""
        h = self.ground.below_sensor_m + rng[:, None] * self._tan_ring[None, :]
        h = np.where(h > self.cfg.ground_clearance_m, h, np.inf)
        return np.asarray(h.min(axis=1))

    def _expected_hits(self, rng: NDArray[np.float64], size: ConeSize,
                       az_step_rad: float) -> NDArray[np.float64]:
        """Expected returns (K, rings) on each ring of a cone of ``size`` at range ``rng`` (K,)."""
        h = self.ground.below_sensor_m + rng[:, None] * self._tan_ring[None, :]
        w = 2.0 * cone_radius_m(size, h)
        w = np.where(h > self.cfg.ground_clearance_m, w, 0.0)
        return w / (np.maximum(rng, 1e-3)[:, None] * az_step_rad)


def _components(x: NDArray[np.float64], y: NDArray[np.float64], dist_m: float
                ) -> NDArray[np.int64]:
    """Connected components of points closer than ``dist_m`` (labels 0..K-1), (N,)."""
    n = x.size
    if n > 256:  # many surfaces (vegetation, barriers): a k-d tree instead of a dense matrix
        from scipy.sparse import coo_matrix
        from scipy.sparse.csgraph import connected_components
        from scipy.spatial import cKDTree

        pairs = cKDTree(np.c_[x, y]).query_pairs(dist_m, output_type="ndarray")
        graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
        _, labels = connected_components(graph, directed=False)
        return labels.astype(np.int64)
    dx = x[:, None] - x[None, :]
    dy = y[:, None] - y[None, :]
    adj = (dx * dx + dy * dy) < dist_m * dist_m
    label = np.arange(n)
    # label propagation: each point takes the smallest label of its neighbours until stable
    while True:
        new = np.where(adj, label[None, :], n).min(axis=1)
        new = np.minimum(new, label)
        new = new[new]
        if np.array_equal(new, label):
            break
        label = new
    _, dense = np.unique(label, return_inverse=True)
    return dense.astype(np.int64)


def _clustered(x: NDArray[np.float64], y: NDArray[np.float64], radius_m: float,
               max_cones: int) -> NDArray[np.bool_]:
    """Points in a dense group, (N,): those with more than ``max_cones`` points (themselves
    included) within ``radius_m``, and every point within ``radius_m`` of one of them (the
    ends of a row of grass tufts have few neighbours of their own)."""
    dense = _neighbour_counts(x, y, radius_m) > max_cones
    if not dense.any():
        return dense
    from scipy.spatial import cKDTree

    near = cKDTree(np.c_[x[dense], y[dense]]).query(np.c_[x, y], distance_upper_bound=radius_m)[0]
    return np.asarray(near < radius_m)


def _neighbour_counts(x: NDArray[np.float64], y: NDArray[np.float64], radius_m: float
                      ) -> NDArray[np.int64]:
    """How many points (itself included) lie within ``radius_m`` of each point, (N,)."""
    if x.size > 256:
        from scipy.spatial import cKDTree

        tree = cKDTree(np.c_[x, y])
        return np.asarray(tree.query_ball_point(np.c_[x, y], radius_m, return_length=True),
                          dtype=np.int64)
    dx = x[:, None] - x[None, :]
    dy = y[:, None] - y[None, :]
    return ((dx * dx + dy * dy) < radius_m**2).sum(axis=1).astype(np.int64)


def _ring_stats(px: NDArray[np.float64], py: NDArray[np.float64], pz: NDArray[np.float64],
                cx: NDArray[np.float64], cy: NDArray[np.float64], inner_m: float, outer_m: float,
                above_m: float = -math.inf
                ) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    """Of the points (``px``, ``py``, heights ``pz``) (M,) at ``inner_m`` <= d < ``outer_m``
    from each centre (``cx``, ``cy``) (K,): how many are higher than ``above_m``, and the
    lowest height (-inf where there is none). K is a few dozen: the points are first cut to the
    grid cells (of side ``outer_m``) next to a centre's, then paired with every centre."""
    counts = np.zeros(cx.size, dtype=np.int64)
    lowest = np.full(cx.size, -np.inf)
    if px.size == 0 or cx.size == 0 or outer_m <= 0.0:
        return counts, lowest
    x0, y0 = cx.min() - 2.0 * outer_m, cy.min() - 2.0 * outer_m
    nx = int((cx.max() - x0) / outer_m) + 3
    ny = int((cy.max() - y0) / outer_m) + 3
    ix = np.floor((px - x0) / outer_m).astype(np.int64)
    iy = np.floor((py - y0) / outer_m).astype(np.int64)
    inside = (ix >= 0) & (ix < nx) & (iy >= 0) & (iy < ny)
    near_cell = np.zeros((nx, ny), dtype=bool)
    ccx = np.floor((cx - x0) / outer_m).astype(np.int64)
    ccy = np.floor((cy - y0) / outer_m).astype(np.int64)
    for dx in (-1, 0, 1):
        for dy in (-1, 0, 1):
            near_cell[ccx + dx, ccy + dy] = True
    pick = np.flatnonzero(inside)
    pick = pick[near_cell[ix[pick], iy[pick]]]
    px, py, pz = px[pick], py[pick], pz[pick]
    low = np.full(cx.size, np.inf)
    for start in range(0, px.size, 4096):  # bounded memory for a sweep full of walls
        chunk = slice(start, start + 4096)
        ddx = cx[:, None] - px[None, chunk]
        ddy = cy[:, None] - py[None, chunk]
        d2 = ddx * ddx + ddy * ddy
        ring = (d2 >= inner_m * inner_m) & (d2 < outer_m * outer_m)
        counts += (ring & (pz[None, chunk] > above_m)).sum(axis=1)
        low = np.minimum(low, np.where(ring, pz[None, chunk], np.inf).min(axis=1))
    lowest = np.where(np.isfinite(low), low, -np.inf)
    return counts, lowest
