"""Tentative cones: the camera's cones beyond the LiDAR's reach, for the exploring planner.

While the car explores an unseen track its speed is set by how much of the track it has
mapped (:mod:`planner.exploration_speed`), and the LiDAR's landmarks begin only 14-15 m ahead
(the simulated VLP-16 is low at the front). The camera sees cones further (20 m in the
simulator), less exactly (about 0.3 m at 15-20 m, where the LiDAR is right to 1 cm). A camera
cone that no landmark explains is kept here, in the world frame at the pose of the image:
the same cone in the next frames (within the gate: ``gate_m``, or with ``gate_sigmas`` set
that many of the camera's standard deviations at its range where more) votes its colour and
moves its position, the mean of all its frames' weighted by the camera's precision at each
one's range (``sigma_at_zero_m``, ``sigma_per_m``: the nearer frames count more); two kept
cones nearer each other than the gate are folded into one. Once seen in ``min_frames`` frames it is
published beside the landmarks with confidence ``confidence`` (< 1: not a landmark), until a
landmark comes within ``landmark_gate_m`` of it (the LiDAR has it now), the camera has not
seen it for ``max_age_s``, or it is nearer the car than ``min_range_m`` (the LiDAR maps a real
cone there; a phantom must not stand in front of the car). The SLAM never takes them: the map
the car localises on is the LiDAR's.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from common.messages import ConeMap, ConeSize
from common.proximity import near_any, pairs_within
from mapper.colour_votes import voted_colours
from mapper.config import TentativeConfig
from mapper.evaluation import match_cones
from mapper.time_smoother import N_COLOURS

FloatArray = NDArray[np.float64]


class TentativeCones:
    """Camera cones no landmark explains (module docstring): positions (K, 2) (m, world),
    summed weights (K,) (1/m^2: each frame's inverse variance), frames seen (K,), colour votes
    (K, N_COLOURS), last time seen (K,) (s)."""

    def __init__(self, config: TentativeConfig) -> None:
        self.config = config
        self.xy_m = np.zeros((0, 2))
        self.weight = np.zeros(0)
        self.frames = np.zeros(0, np.int64)
        self.votes = np.zeros((0, N_COLOURS))
        self.last_seen_s = np.zeros(0)
        self.ids = np.zeros(0, np.int64)
        self._next_id = -1
        self._version = 0
        """Counts the changes of the cones kept, for :meth:`cone_map`'s cache."""
        self._shown: tuple[int, FloatArray, ConeMap] | None = None

    def __len__(self) -> int:
        return len(self.frames)

    def add(self, world_xy_m: FloatArray, colours: NDArray[np.int64],
            confidences: FloatArray, t_s: float, landmarks_xy_m: FloatArray,
            car_xy_m: tuple[float, float]) -> None:
        """One camera frame's cones (n, 2) (m, world frame at the image's pose), their
        :class:`ConeColour` (n,) and confidence (n,) at ``t_s``; ``landmarks_xy_m`` (M, 2) the
        map's landmarks, ``car_xy_m`` the car's position (m)."""
        c = self.config
        xy = np.asarray(world_xy_m, np.float64).reshape(-1, 2)
        explained = near_any(xy, landmarks_xy_m, c.landmark_gate_m)
        xy, colours, confidences = xy[~explained], colours[~explained], confidences[~explained]
        range_m = np.hypot(xy[:, 0] - car_xy_m[0], xy[:, 1] - car_xy_m[1])
        weights = 1.0 / self.sigma_m(range_m) ** 2
        taken = np.zeros(len(xy), bool)
        if len(xy) and len(self):
            gate_m = self.gate_m(range_m)
            rows, cols, dist = match_cones(xy, self.xy_m, float(gate_m.max()))
            within = dist <= gate_m[rows]
            rows, cols = rows[within], cols[within]
            w_old, w_new = self.weight[cols], weights[rows]
            self.xy_m[cols] = ((self.xy_m[cols] * w_old[:, None] + xy[rows] * w_new[:, None])
                               / (w_old + w_new)[:, None])
            self.weight[cols] += w_new
            self.frames[cols] += 1
            self.votes[cols, colours[rows]] += confidences[rows]
            self.last_seen_s[cols] = t_s
            taken[rows] = True
        new = np.flatnonzero(~taken)
        if len(new):
            votes = np.zeros((len(new), N_COLOURS))
            votes[np.arange(len(new)), colours[new]] = confidences[new]
            self.xy_m = np.vstack([self.xy_m, xy[new]])
            self.weight = np.concatenate([self.weight, weights[new]])
            self.frames = np.concatenate([self.frames, np.ones(len(new), np.int64)])
            self.votes = np.vstack([self.votes, votes])
            self.last_seen_s = np.concatenate([self.last_seen_s, np.full(len(new), t_s)])
            self.ids = np.concatenate([self.ids, self._next_id - np.arange(len(new))])
            self._next_id -= len(new)
        merged = self._merge_duplicates(car_xy_m)
        near_car = np.hypot(self.xy_m[:, 0] - car_xy_m[0],
                            self.xy_m[:, 1] - car_xy_m[1]) < c.min_range_m
        self._keep(~(merged | near_car | near_any(self.xy_m, landmarks_xy_m, c.landmark_gate_m)
                     | (t_s - self.last_seen_s > c.max_age_s)))

    def sigma_m(self, range_m: FloatArray) -> FloatArray:
        """The camera's position standard deviation (m) for a cone ``range_m`` (m) away: the
        configured noise model, ``sigma_at_zero_m + sigma_per_m * range``."""
        return self.config.sigma_at_zero_m + self.config.sigma_per_m * np.asarray(range_m)

    def gate_m(self, range_m: FloatArray) -> FloatArray:
        """The association gate (m) for cones ``range_m`` (m) from the car: ``gate_sigmas``
        of the camera's standard deviation there, ``gate_m`` at least."""
        return np.maximum(self.config.gate_sigmas * self.sigma_m(range_m), self.config.gate_m)

    def _merge_duplicates(self, car_xy_m: tuple[float, float]) -> NDArray[np.bool_]:
        """Fold the cones nearer each other than the gate at their range from the car
        (:meth:`gate_m`, the nearer one's) into the one with the most weight (their weighted
        mean, votes and frames summed); which are gone (K,). One cone seen once too far off its
        track starts a second track, and the frames after feed now one, now the other: both
        were published, a phantom beside the real cone that narrowed the lane (EPFL track 4:
        42 of 55 refused manoeuvres' worst cones were such pairs, about 1 m apart)."""
        gone = np.zeros(len(self), bool)
        range_m = np.hypot(self.xy_m[:, 0] - car_xy_m[0], self.xy_m[:, 1] - car_xy_m[1])
        gate_m = self.gate_m(range_m)
        i, j = pairs_within(self.xy_m, self.xy_m, float(gate_m.max()) if len(self) else 0.0)
        keep = (i < j) & (np.hypot(*(self.xy_m[i] - self.xy_m[j]).T)
                          <= np.minimum(gate_m[i], gate_m[j]))
        i, j = i[keep], j[keep]
        if len(i) == 0:
            return gone
        paired = np.unique(np.r_[i, j])
        for a in paired[np.argsort(-self.weight[paired], kind="stable")]:
            if gone[a]:
                continue
            into = np.r_[j[i == a], i[j == a]]
            into = into[~gone[into]]
            if len(into) == 0:
                continue
            both = np.r_[a, into]
            w = self.weight[both]
            self.xy_m[a] = (self.xy_m[both] * w[:, None]).sum(axis=0) / w.sum()
            self.weight[a] = w.sum()
            self.frames[a] = self.frames[both].sum()
            self.votes[a] = self.votes[both].sum(axis=0)
            self.last_seen_s[a] = self.last_seen_s[both].max()
            gone[into] = True
        return gone

    def clear(self) -> None:
        """Forget them all (the map is frozen: the track is known)."""
        self._keep(np.zeros(len(self), bool))

    def cone_map(self, landmarks_xy_m: FloatArray) -> ConeMap:
        """Those seen in ``min_frames`` frames and still no landmark's, as a :class:`ConeMap`
        (covariance the mean's: the inverse of its summed weights; size unknown, confidence
        ``confidence``, ids < 0)."""
        if (self._shown is not None and self._shown[0] == self._version
                and self._shown[1] is landmarks_xy_m):
            return self._shown[2]
        cone_map = self._cone_map(landmarks_xy_m)
        self._shown = (self._version, landmarks_xy_m, cone_map)
        return cone_map

    def _cone_map(self, landmarks_xy_m: FloatArray) -> ConeMap:
        c = self.config
        show = self.frames >= c.min_frames
        show[show] = ~near_any(self.xy_m[show], landmarks_xy_m, c.landmark_gate_m)
        n = int(np.count_nonzero(show))
        if n == 0:
            return ConeMap.empty()
        return ConeMap(xy_m=self.xy_m[show].copy(),
                       covariance=np.eye(2)[None] / self.weight[show][:, None, None],
                       colour=voted_colours(self.votes[show]),
                       size=np.full(n, int(ConeSize.UNKNOWN), np.int64),
                       confidence=np.full(n, c.confidence), ids=self.ids[show].copy())

    def _keep(self, keep: NDArray[np.bool_]) -> None:
        self._version += 1
        self.xy_m = self.xy_m[keep]
        self.weight = self.weight[keep]
        self.frames = self.frames[keep]
        self.votes = self.votes[keep]
        self.last_seen_s = self.last_seen_s[keep]
        self.ids = self.ids[keep]


def with_tentative(landmarks: ConeMap, tentative: ConeMap) -> ConeMap:
    """The landmarks followed by the tentative cones, one :class:`ConeMap`."""
    if len(tentative) == 0:
        return landmarks
    return ConeMap(xy_m=np.vstack([landmarks.xy_m, tentative.xy_m]),
                   covariance=np.concatenate([landmarks.covariance, tentative.covariance]),
                   colour=np.concatenate([landmarks.colour, tentative.colour]),
                   size=np.concatenate([landmarks.size, tentative.size]),
                   confidence=np.concatenate([landmarks.confidence, tentative.confidence]),
                   ids=np.concatenate([landmarks.ids, tentative.ids]))
