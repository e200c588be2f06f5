"""The time smoother of seed 002 (sections 7.2-7.3): a permanent object list from flickering frames.

Each frame of world-frame objects is matched with the stored objects. Two objects match when
their centres are closer than ``D`` and their sizes agree: the larger height is below
``(1 + S_y)`` times the smaller, the larger width below ``(1 + S_x)`` times the narrower (an
unknown size matches any). On a match the stored object takes a weighted average of position and
size, its confidence rises by ``match_conf`` up to ``conf_limit`` and its match counter by one.
An unmatched detection becomes a new object with a low confidence. Then every object loses
``confidence_decay``, and objects below zero are deleted. Objects outside the sensor's current
detection range (distance and field of view) do not decay: the Mapper must remember the cones it
has passed (seed 002, 7.2 note). Beyond the seed, an object never matched is not spared outside
the range (``protect_min_matches``), so a one-off false detection at the edge of the field of view
dies like any other.

Matching goes through a scipy ``cKDTree`` over the stored objects (rebuilt per frame, n log n),
and is one-to-one within a frame: candidate pairs are taken nearest first (the seed's loop takes
the first match it meets; nearest-first is its order-independent version).
"""

from __future__ import annotations

import logging
import math

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from common.conventions import world_to_vehicle
from common.messages import ConeColour, ConeMap, ConeSize
from mapper.colour_votes import voted_colours
from mapper.config import SmootherConfig

log = logging.getLogger(__name__)

N_COLOURS = len(ConeColour)


class TimeSmoother:
    """Seed 002's time smoother over world-frame objects.

    Object arrays (n objects): ``xy_m`` (n, 2), ``size_m`` (n, 2) width, height (NaN unknown),
    ``confidence`` (n,), ``match_count`` (n,), ``age_frames`` (n,), ``ids`` (n,),
    ``colour_votes`` (n, 5) by :class:`ConeColour`, ``sum_sq_m2`` (n, 2) spread of the matches.
    """

    def __init__(self, config: SmootherConfig) -> None:
        self.config = config
        self.xy_m = np.zeros((0, 2))
        self.size_m = np.zeros((0, 2))
        self.confidence = np.zeros(0)
        self.match_count = np.zeros(0, np.int64)
        self.age_frames = np.zeros(0, np.int64)
        self.ids = np.zeros(0, np.int64)
        self.colour_votes = np.zeros((0, N_COLOURS))
        self.sum_sq_m2 = np.zeros((0, 2))
        self._next_id = 0
        self.frames = 0
        self.raw_objects_total = 0
        """Every detection handed in (the seed's 3580 'objects discovered')."""
        self.created_total = 0
        self.deleted_total = 0

    def __len__(self) -> int:
        return int(self.xy_m.shape[0])

    # -- matching ---------------------------------------------------------------------------

    def _size_match(self, new_size: NDArray[np.float64], old_size: NDArray[np.float64]) -> bool:
        cfg = self.config
        for k, ratio in ((0, cfg.size_ratio_x), (1, cfg.size_ratio_y)):
            a, b = float(new_size[k]), float(old_size[k])
            if math.isnan(a) or math.isnan(b) or a <= 0.0 or b <= 0.0:
                continue
            if max(a, b) >= (1.0 + ratio) * min(a, b):
                return False
        return True

    def match(self, xy_m: NDArray[np.float64], size_m: NDArray[np.float64]) -> NDArray[np.int64]:
        """Index of the stored object each new object (M, 2) matches, or -1; one-to-one."""
        m = xy_m.shape[0]
        result = np.full(m, -1, np.int64)
        n = len(self)
        if m == 0 or n == 0:
            return result
        tree = cKDTree(self.xy_m)
        k = min(4, n)
        dist, idx = tree.query(xy_m, k=k, distance_upper_bound=self.config.match_distance_m)
        dist = np.asarray(dist).reshape(m, k)
        idx = np.asarray(idx).reshape(m, k)
        pairs = [
            (float(dist[i, j]), i, int(idx[i, j]))
            for i in range(m)
            for j in range(k)
            if np.isfinite(dist[i, j])
        ]
        pairs.sort()
        taken = np.zeros(n, bool)
        for _d, i, o in pairs:
            if result[i] >= 0 or taken[o]:
                continue
            if not self._size_match(size_m[i], self.size_m[o]):
                continue
            result[i] = o
            taken[o] = True
        return result

    # -- one frame --------------------------------------------------------------------------

    def update(
        self,
        xy_m: NDArray[np.float64],
        size_m: NDArray[np.float64] | None,
        sensor_pose: tuple[float, float, float],
        colours: NDArray[np.int64] | None = None,
    ) -> NDArray[np.int64]:
        """Apply one frame: world positions (M, 2), sizes (M, 2) width/height or None, the
        sensor's pose (x_m, y_m, yaw_rad) for its detection range, optional colours (M,).

        Returns the index (after this frame's deletions: -1 if deleted) of the object each
        detection was merged into or created as.
        """
        cfg = self.config
        xy_m = np.asarray(xy_m, np.float64).reshape(-1, 2)
        m = xy_m.shape[0]
        size = np.full((m, 2), np.nan) if size_m is None else np.asarray(size_m).reshape(m, 2)
        self.frames += 1
        self.raw_objects_total += m
        matched = self.match(xy_m, size)

        # Matched: weighted average, confidence up to the limit.
        hit = matched >= 0
        if np.any(hit):
            o = matched[hit]
            n_obs = self.match_count[o] + 1.0
            w = 1.0 / (n_obs + 1.0)
            if cfg.position_weight_new > 0.0:
                w = np.maximum(w, cfg.position_weight_new)
            if cfg.position_max_matches > 0:
                w = np.where(n_obs > cfg.position_max_matches, 0.0, w)
            old_xy = self.xy_m[o]
            delta = xy_m[hit] - old_xy
            self.xy_m[o] = old_xy + w[:, None] * delta
            self.sum_sq_m2[o] += (1.0 - w)[:, None] * delta**2
            new_size = size[hit]
            old_size = self.size_m[o]
            blended = old_size + w[:, None] * (new_size - old_size)
            self.size_m[o] = np.where(np.isnan(old_size), new_size,
                                      np.where(np.isnan(new_size), old_size, blended))
            self.confidence[o] = np.minimum(self.confidence[o] + cfg.match_conf, cfg.conf_limit)
            self.match_count[o] += 1
            if colours is not None:
                self._vote(o, np.asarray(colours)[hit])

        # Unmatched: new objects with low confidence.
        new = ~hit
        n_new = int(np.count_nonzero(new))
        first_new = len(self)
        if n_new:
            self.xy_m = np.vstack([self.xy_m, xy_m[new]])
            self.size_m = np.vstack([self.size_m, size[new]])
            self.confidence = np.concatenate([self.confidence, np.full(n_new, cfg.initial_conf)])
            self.match_count = np.concatenate([self.match_count, np.zeros(n_new, np.int64)])
            self.age_frames = np.concatenate([self.age_frames, np.zeros(n_new, np.int64)])
            self.ids = np.concatenate(
                [self.ids, np.arange(self._next_id, self._next_id + n_new, dtype=np.int64)])
            self._next_id += n_new
            self.colour_votes = np.vstack([self.colour_votes, np.zeros((n_new, N_COLOURS))])
            self.sum_sq_m2 = np.vstack([self.sum_sq_m2, np.zeros((n_new, 2))])
            self.created_total += n_new
            if colours is not None:
                self._vote(np.arange(first_new, len(self)), np.asarray(colours)[new])
            matched[new] = np.arange(first_new, len(self))

        # Decay inside the detection range; delete below zero.
        self.age_frames += 1
        decays = self.in_detection_range(sensor_pose) | (self.match_count < cfg.protect_min_matches)
        self.confidence[decays] -= cfg.confidence_decay
        keep = self.confidence >= 0.0
        if not np.all(keep):
            remap = np.full(len(self), -1, np.int64)
            remap[keep] = np.arange(int(np.count_nonzero(keep)))
            self._select(keep)
            matched = remap[matched]
        return matched

    def in_detection_range(self, sensor_pose: tuple[float, float, float]) -> NDArray[np.bool_]:
        """(n,) True for objects inside the sensor's range and field of view at ``sensor_pose``."""
        if len(self) == 0:
            return np.zeros(0, bool)
        rel = world_to_vehicle(self.xy_m, *sensor_pose).reshape(-1, 2)
        r = np.hypot(rel[:, 0], rel[:, 1])
        bearing = np.abs(np.arctan2(rel[:, 1], rel[:, 0]))
        return (r <= self.config.detection_range_m) & (
            bearing <= 0.5 * self.config.detection_fov_rad)

    def _select(self, keep: NDArray[np.bool_]) -> None:
        self.deleted_total += int(np.count_nonzero(~keep))
        for name in ("xy_m", "size_m", "confidence", "match_count", "age_frames", "ids",
                     "colour_votes", "sum_sq_m2"):
            setattr(self, name, getattr(self, name)[keep])

    def _vote(self, objects: NDArray[np.int64], colours: NDArray[np.int64],
              weights: NDArray[np.float64] | None = None) -> None:
        colours = np.asarray(colours, np.int64)
        ok = (colours > int(ConeColour.UNKNOWN)) & (colours < N_COLOURS) & (objects >= 0)
        w = np.ones(len(colours)) if weights is None else np.asarray(weights, np.float64)
        np.add.at(self.colour_votes, (objects[ok], colours[ok]), w[ok])

    def add_colour_votes(self, xy_m: NDArray[np.float64], colours: NDArray[np.int64],
                         gate_m: float, weights: NDArray[np.float64] | None = None) -> int:
        """Camera cones (world (K, 2), colours (K,)) vote for the nearest object within
        ``gate_m``; returns how many voted."""
        xy_m = np.asarray(xy_m, np.float64).reshape(-1, 2)
        if len(self) == 0 or xy_m.shape[0] == 0:
            return 0
        dist, idx = cKDTree(self.xy_m).query(xy_m, k=1, distance_upper_bound=gate_m)
        ok = np.isfinite(dist)
        if weights is not None:
            weights = np.asarray(weights, np.float64)[ok]
        self._vote(np.asarray(idx)[ok], np.asarray(colours)[ok], weights)
        return int(np.count_nonzero(ok))

    # -- output -----------------------------------------------------------------------------

    def published(self) -> NDArray[np.bool_]:
        """(n,) True for objects matched at least ``publish_min_matches`` times."""
        return self.match_count >= self.config.publish_min_matches

    def colours(self) -> NDArray[np.int64]:
        """(n,) each object's colour by vote (:func:`mapper.colour_votes.voted_colours`:
        UNKNOWN until a colour leads by a full vote)."""
        return voted_colours(self.colour_votes)

    def confirmed_map(self, min_matches: int, sigma_floor_m: float = 0.05) -> ConeMap:
        """The objects matched at least ``min_matches`` times as a :class:`ConeMap`."""
        return self.cone_map(sigma_floor_m, self.match_count >= min_matches)

    def cone_map(self, sigma_floor_m: float = 0.05,
                 select: NDArray[np.bool_] | None = None) -> ConeMap:
        """The published objects (or those ``select`` (n,) picks) as a :class:`ConeMap`
        (covariance from the matches' spread)."""
        sel = self.published() if select is None else select
        n = int(np.count_nonzero(sel))
        count = self.match_count[sel] + 1.0
        var = self.sum_sq_m2[sel] / (np.maximum(count - 1.0, 1.0) * count)[:, None]
        var = np.maximum(var, sigma_floor_m**2)
        cov = np.zeros((n, 2, 2))
        cov[:, 0, 0] = var[:, 0]
        cov[:, 1, 1] = var[:, 1]
        colour = self.colours()[sel]
        height = self.size_m[sel, 1]
        size = np.where(colour == int(ConeColour.BIG_ORANGE), int(ConeSize.LARGE),
                        np.where(np.isnan(height), int(ConeSize.UNKNOWN),
                                 np.where(height > 0.42, int(ConeSize.LARGE),
                                          int(ConeSize.SMALL))))
        return ConeMap(
            xy_m=self.xy_m[sel].copy(),
            covariance=cov,
            colour=colour,
            size=size.astype(np.int64),
            confidence=self.confidence[sel].copy(),
            ids=self.ids[sel].copy(),
        )
