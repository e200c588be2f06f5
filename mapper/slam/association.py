"""Data association: which landmark each detection of a sweep is (seed 000, 5.3; 6.2.4).

Each detection is compared with every active landmark in reach by its Mahalanobis distance
under the predicted measurement covariance ``S = H P H^T + R``: pairs outside the chi-square
gate (``gate_probability``, 2 dof) are impossible; the sweep's detections are then assigned
all at once (``scipy.optimize.linear_sum_assignment``), beyond the seed's nearest neighbour
(its future work, 6.2.4). A detection close to any landmark (inside the wider
``new_landmark_probability`` gate, or nearer than ``new_landmark_min_distance_m``; than
``new_landmark_min_distance_other_size_m`` to a landmark of the other size class, as a big cone
stands by a small one at the start line) but not assigned is ambiguous: it never becomes a new
landmark.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import linear_sum_assignment

from common.messages import ConeSize
from mapper.chi2 import chi2_ppf
from mapper.config import SlamConfig
from mapper.slam.ekf import SlamEkf
from mapper.slam.landmarks import BIG
from mapper.slam.models import FloatArray, inv2, observation_model

UNKNOWN_SIZE = int(ConeSize.UNKNOWN)


@dataclass(frozen=True)
class Association:
    """One sweep's association: detection ``detections[i]`` is landmark ``landmarks[i]``;
    ``near_any`` (k,) marks the detections close to some landmark (assigned or not)."""

    detections: NDArray[np.int64]
    landmarks: NDArray[np.int64]
    near_any: NDArray[np.bool_]


class Associator:
    """Associates a sweep's detections with the filter's landmarks (module docstring)."""

    def __init__(self, cfg: SlamConfig) -> None:
        self.cfg = cfg
        self.gate = chi2_ppf(cfg.gate_probability, 2)
        self.new_gate = chi2_ppf(cfg.new_landmark_probability, 2)

    def associate(self, ekf: SlamEkf, z: FloatArray, r: FloatArray,
                  active: NDArray[np.bool_], sizes: NDArray[np.int64] | None = None,
                  landmark_sizes: NDArray[np.int64] | None = None) -> Association:
        """Detections ``z`` (k, 2) in the vehicle frame at the filter's time with noise ``r``
        (k, 2, 2), against the landmarks marked ``active`` (N,) within the LiDAR's reach.
        ``sizes`` (k,) and ``landmark_sizes`` (N,) (:class:`~common.messages.ConeSize`): a
        detection beside a landmark of the other size class is ambiguous only within
        ``new_landmark_min_distance_other_size_m``."""
        c = self.cfg
        n_det = z.shape[0]
        assigned_det = np.zeros(0, np.int64)
        assigned_lm = np.zeros(0, np.int64)
        near_any = np.zeros(n_det, bool)
        if ekf.n_landmarks:
            xbuf = ekf.xbuf
            lm_xy = ekf.landmarks_view()
            reach = c.max_range_m + 3.0
            dist = np.hypot(lm_xy[:, 0] - xbuf[0], lm_xy[:, 1] - xbuf[1])
            cand = np.flatnonzero(active & (dist <= reach))
            if cand.size:
                zhat, hp, hl = observation_model(xbuf[:3], lm_xy[cand])
                ppl, pll = ekf.landmark_blocks(cand)
                ppp = ekf.pbuf[:3, :3]
                hpp = np.einsum("mij,jk,mlk->mil", hp, ppp, hp)
                cross = np.einsum("mij,mjk,lk->mil", hp, ppl, hl)
                spred = hpp + cross + cross.transpose(0, 2, 1) + hl @ pll @ hl.T
                y = z[:, None, :] - zhat[None, :, :]                     # (k, m, 2)
                s_pair = spred[None, :, :, :] + r[:, None, :, :]
                d2 = np.einsum("kmi,kmij,kmj->km", y, inv2(s_pair), y)
                near_any = np.min(d2, axis=1) <= self.new_gate
                eucl = np.hypot(y[..., 0], y[..., 1])
                floor = np.full(eucl.shape, c.new_landmark_min_distance_m)
                if sizes is not None and landmark_sizes is not None:
                    mine, theirs = sizes[:, None], landmark_sizes[cand][None, :]
                    other = (mine != UNKNOWN_SIZE) & (theirs != UNKNOWN_SIZE) & (mine != theirs)
                    floor[other] = c.new_landmark_min_distance_other_size_m
                near_any |= np.any(eucl < floor, axis=1)
                cost = np.where(d2 <= self.gate, d2, BIG)
                rows, cols = linear_sum_assignment(cost)
                good = cost[rows, cols] < BIG
                assigned_det, assigned_lm = rows[good], cand[cols[good]]
        return Association(assigned_det, assigned_lm, near_any)
