"""Seed 001's cone measurement against a known map, in the UKF (:class:`ConeMapUpdate`).

Each detection d paired with its map cone m gives the car's position in the seed's *position
form*: z = m - R(yaw_hat) d. The update is masked to the position (seed 001: "only the position
is updated"), with the gain computed from the linearisation H = [I, dR/dyaw d] so that the yaw
uncertainty is accounted for, and the covariance in Joseph form (exact for the masked,
sub-optimal gain); one batched update per sweep. When the map's errors are the UKF's consider
states (a map handed over by the SLAM: :meth:`UkfLocaliser.set_map`) the update accounts for
them and their correlation with the pose (:meth:`ConeMapUpdate._consider`).
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from common.conventions import wrap_angle
from common.messages import ConeDetection, ConeMap
from mapper.spd_solve import cho_solve_lower, cholesky_lower
from mapper.ukf_state import IW, IX, IY, IYAW

if TYPE_CHECKING:
    from mapper.ukf_localiser import UkfLocaliser

FloatArray = NDArray[np.float64]


class ConeMapUpdate:
    """The cone update of a :class:`~mapper.ukf_localiser.UkfLocaliser` (module docstring);
    keeps the k-d tree of the last map it paired cones with."""

    def __init__(self) -> None:
        self._tree: cKDTree | None = None
        self._tree_map: ConeMap | None = None

    def update(self, ukf: UkfLocaliser, cones: Sequence[ConeDetection], cone_map: ConeMap,
               cones_xy_m: FloatArray | None = None, full_update: bool = False,
               cone_sigma_m: float | None = None) -> int:
        """Seed 001's cones model against a known map; returns how many cones were applied.

        ``cones`` are vehicle-frame detections (their positions may be given motion-compensated
        as ``cones_xy_m`` (N, 2)); each is paired with the nearest map cone within
        ``cone_association_m`` of its predicted world position, gated one by one (Mahalanobis),
        then all go in one batched, position-masked update (``full_update``: an unmasked one,
        yaw and IMU biases too); ``cone_sigma_m`` overrides the configured detection noise.
        """
        cfg = ukf.config
        if not cfg.use_cones or len(cone_map) == 0 or not cones:
            return 0
        if abs(ukf.x[IW]) > cfg.cone_max_yaw_rate_radps:
            ukf.count("cones", "skipped_turning")
            return 0
        if self._tree_map is not cone_map:
            self._tree = cKDTree(cone_map.xy_m)
            self._tree_map = cone_map
        assert self._tree is not None
        d = (np.array([(c.x_m, c.y_m) for c in cones], np.float64) if cones_xy_m is None
             else np.asarray(cones_xy_m, np.float64).reshape(-1, 2))
        yaw = float(ukf.x[IYAW])
        c, s = math.cos(yaw), math.sin(yaw)
        rot_d = np.stack([c * d[:, 0] - s * d[:, 1], s * d[:, 0] + c * d[:, 1]], axis=1)
        predicted = rot_d + ukf.x[:2]
        dist, idx = self._tree.query(predicted, k=1, distance_upper_bound=cfg.cone_association_m)
        paired = np.isfinite(dist)
        if not np.any(paired):
            ukf.count("cones", "unassociated")
            return 0
        n_unpaired = int(np.count_nonzero(~paired))
        if n_unpaired:
            ukf.stats.setdefault("cones", Counter())["unassociated"] += n_unpaired
        m = cone_map.xy_m[idx[paired]]
        rd = rot_d[paired]
        z = m - rd  # seed 001's position form: where the car is, seen from each cone
        y_all = z - ukf.x[:2]
        # With m = p + R(yaw) d + noise: z - p_hat ~ (p - p_hat) + J (yaw - yaw_hat), where
        # J = dR/dyaw d = (-rd_y, rd_x): H = [I, J] on (x, y, yaw).
        J = np.stack([-rd[:, 1], rd[:, 0]], axis=1)
        sigma = cfg.cone_sigma_m if cone_sigma_m is None else cone_sigma_m
        mask: tuple[int, ...] | None = (IX, IY, IYAW) if cfg.cone_update_heading else (IX, IY)
        if full_update:
            mask = None
        if ukf.PxL is not None and cone_map is ukf.consider_map:
            return self._consider(ukf, y_all, J, idx[paired], sigma, mask)
        R_each = sigma**2 * np.eye(2) + cone_map.covariance[idx[paired]]
        P3 = ukf.P[:3, :3]
        accepted = []
        for i in range(z.shape[0]):
            Hi = np.array([[1.0, 0.0, J[i, 0]], [0.0, 1.0, J[i, 1]]])
            Si = Hi @ P3 @ Hi.T + R_each[i]
            yi = y_all[i]
            d2 = float(yi @ np.linalg.solve(Si, yi))
            if d2 <= cfg.cone_gate_sigma**2:
                accepted.append(i)
            else:
                ukf.count("cones", "rejected")
        if not accepted:
            return 0
        k = len(accepted)
        H = np.zeros((2 * k, ukf.n))
        R = np.zeros((2 * k, 2 * k))
        for j, i in enumerate(accepted):
            H[2 * j, IX] = 1.0
            H[2 * j + 1, IY] = 1.0
            H[2 * j, IYAW] = J[i, 0]
            H[2 * j + 1, IYAW] = J[i, 1]
            R[2 * j:2 * j + 2, 2 * j:2 * j + 2] = R_each[i]
        y = y_all[accepted].reshape(-1)
        ok = ukf.update_linear("cones_batch", y, H, R, gate=math.inf, mask=mask)
        if ok:
            ukf.stats.setdefault("cones", Counter())["applied"] += k
        return k if ok else 0

    def _consider(self, ukf: UkfLocaliser, y_all: FloatArray, J: FloatArray,
                               landmarks: NDArray[np.intp], sigma_m: float,
                               mask: tuple[int, ...] | None) -> int:
        """The cone update with the map's errors as consider states (see :meth:`set_map`).

        ``y_all`` (p, 2) innovations z - p_hat, ``J`` (p, 2) their yaw derivatives, ``landmarks``
        (p,) the paired map cones. ``y = H_x e_x - e_L[cone] + v``: its covariance
        ``S = H P H^T - H P_xL_c - P_Lx_c H^T + P_LL_cc + sigma^2 I``; each detection is gated on
        its own 2 x 2 block, the accepted go in one update with the (masked) gain
        ``K = M S^-1``, ``M = cov(e_x, y) = P H^T - P_xL_c``, the covariance in the form exact
        for any gain ``P - K M^T - M K^T + K S K^T``, and ``P_xL -= K cov(y, e_L)``.
        """
        cfg = ukf.config
        assert ukf.PxL is not None and ukf.map_cov is not None
        p = y_all.shape[0]
        Hx = np.zeros((2 * p, ukf.n))
        Hx[0::2, IX] = 1.0
        Hx[1::2, IY] = 1.0
        Hx[0::2, IYAW] = J[:, 0]
        Hx[1::2, IYAW] = J[:, 1]
        cols = np.empty(2 * p, np.intp)
        cols[0::2] = 2 * landmarks
        cols[1::2] = 2 * landmarks + 1
        pxl_c = ukf.PxL[:, cols]
        M = ukf.P @ Hx.T - pxl_c
        B = Hx @ pxl_c
        S = Hx @ M - B.T + ukf.map_cov[np.ix_(cols, cols)]
        S[np.diag_indices(2 * p)] += sigma_m**2
        S = 0.5 * (S + S.T)
        gate2 = cfg.cone_gate_sigma**2
        accepted = []
        for i in range(p):
            yi = y_all[i]
            Si = S[2 * i:2 * i + 2, 2 * i:2 * i + 2]
            det = Si[0, 0] * Si[1, 1] - Si[0, 1] * Si[1, 0]
            d2 = (Si[1, 1] * yi[0] * yi[0] - 2.0 * Si[0, 1] * yi[0] * yi[1]
                  + Si[0, 0] * yi[1] * yi[1]) / det if det > 0.0 else math.inf
            if d2 <= gate2:
                accepted.append(i)
            else:
                ukf.count("cones", "rejected")
        if not accepted:
            return 0
        rows = np.empty(2 * len(accepted), np.intp)
        rows[0::2] = 2 * np.asarray(accepted)
        rows[1::2] = rows[0::2] + 1
        Sa = S[np.ix_(rows, rows)]
        Ma = M[:, rows]
        try:
            cho = cholesky_lower(Sa)
        except (np.linalg.LinAlgError, ValueError):
            ukf.count("cones_batch", "rejected_singular")
            return 0
        K = cho_solve_lower(cho, Ma.T).T
        if mask is not None:
            drop = np.ones(ukf.n, bool)
            drop[list(mask)] = False
            K[drop] = 0.0
        ukf.x = ukf.x + K @ y_all[accepted].reshape(-1)
        ukf.x[IYAW] = wrap_angle(float(ukf.x[IYAW]))
        KM = K @ Ma.T
        P = ukf.P - KM - KM.T + K @ Sa @ K.T
        ukf.P = 0.5 * (P + P.T)
        c_yl = Hx[rows] @ ukf.PxL - ukf.map_cov[cols[rows]]
        ukf.PxL = ukf.PxL - K @ c_yl
        ukf.count("cones_batch", "applied")
        k = len(accepted)
        ukf.stats.setdefault("cones", Counter())["applied"] += k
        return k
