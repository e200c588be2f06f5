"""The EKF's predict and update numerics on the SLAM state and its covariance (seed 000, 5.3).

The state ``x`` (V + 2 N,) and covariance ``P`` live in buffers with spare capacity
(:attr:`SlamEkf.xbuf`, :attr:`SlamEkf.pbuf`, the first :attr:`SlamEkf.n` rows in use), so that
a new landmark does not copy them. Numerical care (seed 000, 5.3.4-5.3.5): double precision, no
explicit inverse, an exactly symmetric ``P`` wherever it is read.

- Prediction (eq. 5.8 in block form): only the vehicle block changes at each IMU sample; the
  vehicle-landmark cross block is multiplied by the accumulated pose Jacobian lazily, once
  before the next update that needs it, so a prediction costs O(1) and a flush O(N).
- Updates touching only vehicle states (odometry, GPS) change the vehicle block at once and
  leave the landmarks to the same flush (Guivant and Nebot's compressed filter: exact).
- Other updates: ``P <- P - K (H P)`` with ``S = L L^T`` (Cholesky, LAPACK ``dpotrf``),
  ``K (H P) = V V^T`` with ``V = (H P)^T L^-T`` (BLAS ``dtrsm``) and ``K y = V (L^-1 y)``;
  ``H`` is used only on the columns it touches. ``V V^T`` is subtracted by ``dsyrk`` in place on
  the lower triangle of ``P`` (:mod:`mapper.slam.blas`); the upper triangle of the landmark
  block is then stale and mirrored from the lower one before anyone reads the whole ``P``, so
  the lower triangle is the one truth (the triangles cannot drift).
"""

from __future__ import annotations

import logging
import math
from collections import Counter

import numpy as np
from numpy.typing import NDArray
from scipy.linalg.blas import dtrsm, dtrsv
from scipy.linalg.lapack import dpotrf, dpotrs

from common.conventions import wrap_angle
from mapper.config import SlamConfig
from mapper.slam.blas import mirror_lower, syrk_lower_inplace
from mapper.slam.models import BIAS_DIM, POSE_DIM, FloatArray

log = logging.getLogger(__name__)

_SYMMETRISE_EVERY = 50
"""Updates between explicit symmetrisations when the update runs in numpy (the BLAS path keeps
the lower triangle as the only truth, so the triangles cannot drift apart)."""


class SlamEkf:
    """The SLAM state and covariance with their prediction and updates (module docstring).

    ``xbuf`` / ``pbuf`` are the buffers (use the first ``n`` rows; replaced when they grow);
    ``vdim`` is the number of vehicle states (5, or 8 with the IMU biases); ``stats`` counts
    skipped updates.
    """

    def __init__(self, cfg: SlamConfig, stats: Counter[str]) -> None:
        self.cfg = cfg
        self.stats = stats
        self.vdim = POSE_DIM + (BIAS_DIM if cfg.imu_bias_states else 0)
        cap = self.vdim + 2 * 64
        self.xbuf = np.zeros(cap)
        self.pbuf = np.zeros((cap, cap))
        self.n = self.vdim
        self.pbuf[:self.vdim, :self.vdim] = np.diag(self._initial_vehicle_variances())
        self.reset_lazy()
        self._lower_only = False
        """The strict upper triangle of the landmark block ``P[V:, V:]`` is stale: the lower
        triangle is the covariance there (see :meth:`update`); :meth:`mirror` restores it."""
        self._scratch = np.empty(0)
        self._q_input = np.array([cfg.gyro_noise_density_radps_rthz,
                                  cfg.accel_noise_density_mps2_rthz,
                                  cfg.accel_noise_density_mps2_rthz]) ** 2
        """Input noise densities squared; divided by the step for Q (seed 000)."""
        self._q_walk = np.array([cfg.gyro_bias_walk_radps_rths, cfg.accel_bias_walk_mps2_rths,
                                 cfg.accel_bias_walk_mps2_rths]) ** 2
        self._bias_diag = (POSE_DIM + BIAS_DIM + 1) * np.arange(POSE_DIM, POSE_DIM + BIAS_DIM)
        """Flat indices of the bias states' diagonal in the (8, 8) vehicle block."""
        self._cone_index: dict[int, tuple[NDArray[np.int64], ...]] = {}
        """Index arrays of the batched cone update by number of detections (_cone_structure)."""
        self._vehicle_upper = np.triu(np.ones((POSE_DIM + BIAS_DIM,) * 2, bool), 1)
        """Strict upper triangle of the largest vehicle block (8, 8)."""
        self._updates = 0

    def _initial_vehicle_variances(self) -> FloatArray:
        c = self.cfg
        sig = [c.initial_position_sigma_m, c.initial_position_sigma_m, c.initial_yaw_sigma_rad,
               c.initial_velocity_sigma_mps, c.initial_velocity_sigma_mps]
        if self.vdim > POSE_DIM:
            sig += [c.initial_gyro_bias_sigma_radps, c.initial_accel_bias_sigma_mps2,
                    c.initial_accel_bias_sigma_mps2]
        return np.asarray(sig, np.float64) ** 2

    # ----------------------------------------------------------------------------------------
    # State access
    # ----------------------------------------------------------------------------------------

    @property
    def x(self) -> FloatArray:
        """The state vector (V + 2 N,), a view (landmark means brought up to date)."""
        self.flush_mean()
        return self.xbuf[: self.n]

    @property
    def P(self) -> FloatArray:  # noqa: N802 (the conventional name)
        """The covariance (V + 2 N, V + 2 N), exactly symmetric, a view (cross blocks brought up
        to date) valid until the next update."""
        self.flush()
        self.mirror()
        return self.pbuf[: self.n, : self.n]

    @property
    def n_landmarks(self) -> int:
        """Number of landmarks in the filter."""
        return (self.n - self.vdim) // 2

    def landmarks_view(self) -> FloatArray:
        """Landmark positions (N, 2), a view of the buffer as it is (no flush)."""
        return self.xbuf[self.vdim: self.n].reshape(-1, 2)

    def load(self, x: FloatArray, p: FloatArray) -> None:
        """Replace the state (V + 2 N,) and covariance; ``V`` is 5 for an odd-sized state (no
        bias states) and 8 for an even-sized one."""
        n = x.size
        self.vdim = POSE_DIM if n % 2 else POSE_DIM + BIAS_DIM
        if n < self.vdim or (n - self.vdim) % 2 or p.shape != (n, n):
            raise ValueError(f"load_state: bad shapes x {x.shape}, P {p.shape}")
        cap = max(self.xbuf.size, n)
        self.xbuf = np.zeros(cap)
        self.pbuf = np.zeros((cap, cap))
        self.xbuf[:n] = x
        self.pbuf[:n, :n] = p
        self.n = n
        self.reset_lazy()
        self._lower_only = False

    # ----------------------------------------------------------------------------------------
    # The lazy cross blocks
    # ----------------------------------------------------------------------------------------

    def reset_lazy(self) -> None:
        v = self.vdim
        self._f_full = np.eye(v)
        """The vehicle block's prediction Jacobian, reused: identity but for its first rows."""
        self._f_acc = np.eye(v)
        self._f_pending = False
        self._lazy_b = np.zeros((v, v))
        self._lazy_c = np.zeros(v)
        self._b_pending = False
        self._c_pending = False

    def flush_mean(self) -> None:
        """Apply the pending vehicle-only updates to the landmark means: ``x_L += P_Lv0 c``."""
        if not self._c_pending:
            return
        v, n = self.vdim, self.n
        if n > v:
            self.xbuf[v:n] += self._lazy_c @ self.pbuf[:v, v:n]
        self._lazy_c = np.zeros(v)
        self._c_pending = False

    def flush(self) -> None:
        """Bring the landmark blocks up to date (eq. 5.8 and the compressed updates).

        Predictions and updates that touch only the vehicle states (odometry, GPS) change the
        vehicle block at once and leave the landmarks to this: with ``P_vL0``, ``P_LL0``,
        ``x_L0`` as they were at the last flush, the cross block is ``M P_vL0`` (``M`` the
        product of the prediction Jacobians and the updates' ``I - K_v H``), the landmark block
        ``P_LL0 - P_Lv0 B P_vL0`` and the means ``x_L0 + P_Lv0 c`` (``B``, ``c`` summed over the
        updates). Exact, and O(V) per update instead of O(N^2) (Guivant and Nebot's compressed
        filter)."""
        self.flush_mean()
        if not (self._f_pending or self._b_pending):
            return
        v, n = self.vdim, self.n
        if n > v:
            p = self.pbuf
            cross0 = p[:v, v:n]
            if self._b_pending:
                bc = self._lazy_b @ cross0
                p[v:n, v:n] -= cross0.T @ bc
                # Not exactly symmetric in floating point: the lower triangle is the truth.
                self._lower_only = True
            cross = self._f_acc @ cross0 if self._f_pending else cross0.copy()
            p[:v, v:n] = cross
            p[v:n, :v] = cross.T
        self._f_acc = np.eye(v)
        self._f_pending = False
        self._lazy_b = np.zeros((v, v))
        self._b_pending = False

    # ----------------------------------------------------------------------------------------
    # Prediction
    # ----------------------------------------------------------------------------------------

    def predict(self, pose: FloatArray, f5: FloatArray, g: FloatArray, dt: float) -> None:
        """The pose moved to ``pose`` (5,) by the motion model, with its Jacobians ``f5`` (5, 5)
        and ``g`` (5, 3) over ``dt`` (s): the vehicle block of ``P`` with the input noise
        ``Q = G diag(s_g^2, s_a^2, s_a^2) / T G^T`` (and the bias random walk); the cross block
        later (:meth:`flush`). The inputs are (measurement - bias): d pose / d bias = -G (the
        lever arm's gyro-bias terms are far below the noise and left out)."""
        pd = self.vdim
        self.xbuf[:POSE_DIM] = pose
        q_u = self._q_input / dt
        pxx = self.pbuf[:pd, :pd]
        if pd == POSE_DIM:
            f = f5
            new_pxx = f @ pxx @ f.T + (g * q_u) @ g.T
        else:
            f = self._f_full                                   # identity outside these
            f[:POSE_DIM, :POSE_DIM] = f5
            np.negative(g, out=f[:POSE_DIM, POSE_DIM:])
            new_pxx = f @ pxx @ f.T
            new_pxx[:POSE_DIM, :POSE_DIM] += (g * q_u) @ g.T
            new_pxx.flat[self._bias_diag] += self._q_walk * dt
        pxx[...] = new_pxx
        pxx += new_pxx.T
        pxx *= 0.5
        self._f_acc = f @ self._f_acc
        self._f_pending = True

    # ----------------------------------------------------------------------------------------
    # Updates
    # ----------------------------------------------------------------------------------------

    def update(self, cols: NDArray[np.int64], h: FloatArray, innovation: FloatArray,
               r: FloatArray) -> bool:
        """EKF update with ``H`` non-zero only on the state columns ``cols``.

        ``h`` (k, len(cols)) is that part of H, ``innovation`` (k,) = z - h(x), ``r`` (k, k).
        ``P <- P - K (H P)`` with Cholesky solves; returns False (counted) if S is not positive
        definite.

        With ``S = L L^T``, ``K (H P) = V V^T`` where ``V = (H P)^T L^-T`` (n, k): one BLAS
        ``dsyrk`` subtracts it from the LOWER triangle of P in place (half the multiply-adds of
        the full product, no (n, n) temporary; :func:`mapper.slam.blas.syrk_lower_inplace`).
        The vehicle rows are then mirrored at once (V of them); the upper triangle of the
        landmark block stays stale until someone needs the whole matrix (:meth:`mirror`: the
        ``P`` property, the loop closure). Readers of landmark rows take them from the lower
        triangle (the rows below: :meth:`rows`).
        """
        self.flush()
        n = self.n
        p = self.pbuf[:n, :n]
        hp = h @ self.rows(cols)                               # (k, n) = H P
        s = hp[:, cols] @ h.T + r
        # S = L L^T (LAPACK directly: scipy's cho_factor/cho_solve cost more in argument
        # checking than the 40 x 40 factorisation).
        chol, info = dpotrf(s, lower=1, clean=0, overwrite_a=1)
        if info != 0:
            self.stats["update_not_positive_definite"] += 1
            log.warning("EKF SLAM update skipped: S not positive definite")
            return False
        # V = (H P)^T L^-T: one BLAS triangular solve with the Cholesky factor, (n, k), in
        # place of H P (no longer needed); K y = (H P)^T S^-1 y = V (L^-1 y).
        vt = dtrsm(1.0, chol, hp.T, side=1, lower=1, trans_a=1, overwrite_b=1)
        self.xbuf[:n] += vt @ dtrsv(chol, innovation, lower=1)
        if syrk_lower_inplace(p, vt):
            v = min(self.vdim, n)
            pvv = p[:v, :v]
            np.copyto(pvv, pvv.T.copy(), where=self._vehicle_upper[:v, :v])
            p[:v, v:] = p[v:, :v].T
            self._lower_only = n > v
        else:
            # No BLAS reachable: the full product (numpy calls syrk and mirrors it, exactly
            # symmetric) into a buffer kept between updates (a fresh one is page-faulted in on
            # every update: 3 ms instead of 0.5 at n 600).
            if self._scratch.size < n * n:
                self._scratch = np.empty(max(n * n, 2 * self._scratch.size))
            vvt = self._scratch[:n * n].reshape(n, n)
            np.matmul(vt, vt.T, out=vvt)
            p -= vvt
            self._updates += 1
            if self._updates % _SYMMETRISE_EVERY == 0:
                self.symmetrise()
        self.xbuf[2] = wrap_angle(float(self.xbuf[2]))
        return True

    def rows(self, cols: NDArray[np.int64]) -> FloatArray:
        """Rows ``cols`` of the (symmetric) covariance (k, n), a new array: with a stale upper
        triangle the part right of the diagonal comes from the column."""
        n = self.n
        p = self.pbuf[:n, :n]
        rows = p[cols, :]
        if self._lower_only:
            c_min = int(cols.min()) if cols.size else n
            part = rows[:, c_min:]
            np.copyto(part, p[c_min:, cols].T,
                      where=np.arange(c_min, n)[None, :] > cols[:, None])
        return rows

    def mirror(self) -> None:
        """Make P exactly symmetric again from its lower triangle if the upper one is stale."""
        if self._lower_only:
            v = self.vdim
            mirror_lower(self.pbuf[v: self.n, v: self.n])
            self._lower_only = False

    def symmetrise(self) -> None:
        """Make P exactly symmetric: from the lower triangle if the upper one is stale, else
        ``P = (P + P^T) / 2`` (the rank-k update is symmetric already; this guards round-off)."""
        if self._lower_only:
            self.mirror()
            return
        p = self.pbuf[: self.n, : self.n]
        p[...] = 0.5 * (p + p.T)

    def update_vehicle(self, cols: NDArray[np.int64], h: FloatArray, innovation: FloatArray,
                       r: FloatArray) -> bool:
        """EKF update whose ``H`` touches only vehicle states (``cols`` < V): the vehicle block
        now, the landmarks lazily (see :meth:`flush`)."""
        v = self.vdim
        hv = np.zeros((h.shape[0], v))
        hv[:, cols] = h
        pvv = self.pbuf[:v, :v]
        hp = hv @ pvv                                          # (k, V)
        s = hp @ hv.T + r
        # LAPACK directly (cho_factor/cho_solve add ~20 us of checks to a 2 x 2 solve, and
        # this runs at the odometry rate)
        chol, info = dpotrf(s, lower=1, clean=0, overwrite_a=1)
        if info != 0:
            self.stats["update_not_positive_definite"] += 1
            log.warning("EKF SLAM update skipped: S not positive definite")
            return False
        rhs = np.empty((s.shape[0], 2 * v + 1), order="F")
        rhs[:, :v] = hv
        rhs[:, v:2 * v] = hp
        rhs[:, 2 * v] = innovation
        sol, info = dpotrs(chol, rhs, lower=1, overwrite_b=1)  # one solve for all three
        s_inv_h = sol[:, :v]                                   # S^-1 H (k, V)
        kt = sol[:, v:2 * v]                                   # K^T = S^-1 H P_vv (k, V)
        s_inv_y = sol[:, 2 * v]
        self.xbuf[:v] += hp.T @ s_inv_y
        new_pvv = pvv - hp.T @ kt
        self.pbuf[:v, :v] = 0.5 * (new_pvv + new_pvv.T)
        if self.n > v:
            m = self._f_acc
            hm = hv @ m                                        # H M (k, V)
            self._lazy_c += hm.T @ s_inv_y
            self._lazy_b += hm.T @ (s_inv_h @ m)
            self._f_acc = m - kt.T @ hm                        # (I - K_v H) M
            self._f_pending = self._b_pending = self._c_pending = True
        self.xbuf[2] = wrap_angle(float(self.xbuf[2]))
        return True

    def landmark_blocks(self, idx: NDArray[np.int64]) -> tuple[FloatArray, FloatArray]:
        """Cross covariances pose(3)-landmark (M, 3, 2) and landmark blocks (M, 2, 2)."""
        p = self.pbuf
        c0 = self.vdim + 2 * idx
        ppl = np.stack([p[:3, c0].T, p[:3, c0 + 1].T], axis=2)
        pll = np.empty((idx.size, 2, 2))
        pll[:, 0, 0] = p[c0, c0]
        pll[:, 0, 1] = pll[:, 1, 0] = p[c0 + 1, c0]          # the lower triangle: see update
        pll[:, 1, 1] = p[c0 + 1, c0 + 1]
        return ppl, pll

    def update_landmarks(self, z: FloatArray, r: FloatArray, lm: NDArray[np.int64]) -> bool:
        """One batched update for detections ``z`` (a, 2) (vehicle frame) of landmarks ``lm``
        (a,) with noise ``r`` (a, 2, 2).

        The model is :func:`~mapper.slam.models.observation_model`'s, written out with as few
        array operations as possible (a sweep's update is dominated by per-call overhead apart
        from the rank-k product): ``H`` (2a, 3 + 2a) on the columns ``x, y, yaw`` and the
        landmarks' is ``[-R^T | R^T (-dy, dx)... | blockdiag(R^T)]`` (:meth:`_cone_structure`).
        """
        a = lm.size
        pd = self.vdim
        xb = self.xbuf
        yaw = float(xb[2])
        c, s = math.cos(yaw), math.sin(yaw)
        hl = np.array([[c, s], [-s, c]])                       # R^T, d z / d l
        cols, pose_idx, yaw_idx, rr_idx = self._cone_structure(a)
        lm_cols = cols[3::2]
        np.add(2 * lm, pd, out=lm_cols)
        np.add(lm_cols, 1, out=cols[4::2])
        zhat = (xb[cols[3:]].reshape(a, 2) - xb[:2]) @ hl.T      # (a, 2) = R^T (l - p)
        h = np.zeros((2 * a, 3 + 2 * a))
        h.put(pose_idx, np.concatenate([-hl.ravel(), hl.ravel()]))  # d/d(x, y) and d/dl
        h.put(yaw_idx, zhat[:, ::-1] * (1.0, -1.0))            # d/d yaw = (zy, -zx)
        rr = np.zeros((2 * a, 2 * a))
        rr.put(rr_idx, r)                                      # blockdiag(r)
        return self.update(cols, h, (z - zhat).ravel(), rr)

    def _cone_structure(self, a: int) -> tuple[NDArray[np.int64], NDArray[np.int64],
                                               NDArray[np.int64], NDArray[np.int64]]:
        """Index arrays of a batched cone update with ``a`` detections, cached by ``a``.

        Returns the state columns (3 + 2a,) (a fresh array: the pose columns set, the
        landmarks' to fill), the flat indices in H (2a, 3 + 2a) of the x, y and landmark
        entries (8 per detection: row 2i: x, y, then row 2i + 1: x, y, then the same for the
        2 x 2 landmark block, in the order ``put`` repeats its 8 values), those of the yaw
        column (2a,) and of the 2 x 2 blocks of blockdiag(R) (2a, 2a) (4 per detection).
        """
        cached = self._cone_index.get(a)
        if cached is None:
            m = 3 + 2 * a
            i = np.arange(a)[:, None]
            row0, row1 = 2 * i * m, (2 * i + 1) * m
            lm0 = 3 + 2 * i
            pose_idx = np.concatenate([row0, row0 + 1, row1, row1 + 1, row0 + lm0,
                                       row0 + lm0 + 1, row1 + lm0, row1 + lm0 + 1], axis=1)
            yaw_idx = np.concatenate([row0 + 2, row1 + 2], axis=1)
            q = 2 * a
            rr_idx = np.concatenate([2 * i * q + 2 * i, 2 * i * q + 2 * i + 1,
                                     (2 * i + 1) * q + 2 * i, (2 * i + 1) * q + 2 * i + 1],
                                    axis=1)
            cols0 = np.zeros(m, np.int64)
            cols0[:3] = (0, 1, 2)
            cached = (cols0, pose_idx.ravel(), yaw_idx.ravel(), rr_idx.ravel())
            self._cone_index[a] = cached
        return cached[0].copy(), cached[1], cached[2], cached[3]

    # ----------------------------------------------------------------------------------------
    # Landmarks in and out
    # ----------------------------------------------------------------------------------------

    def augment(self, z: FloatArray, r: FloatArray) -> None:
        """State augmentation with ``a`` new landmarks ``l = p + R(yaw) z`` (detections ``z``
        (a, 2) in the vehicle frame, noise ``r`` (a, 2, 2)), with their covariance and cross
        terms."""
        self.flush()
        a = z.shape[0]
        n = self.n
        n_new = n + 2 * a
        if n_new > self.xbuf.size:
            cap = max(2 * self.xbuf.size, n_new)
            xbuf = np.zeros(cap)
            xbuf[:n] = self.xbuf[:n]
            pbuf = np.zeros((cap, cap))
            pbuf[:n, :n] = self.pbuf[:n, :n]
            self.xbuf, self.pbuf = xbuf, pbuf
        yaw = float(self.xbuf[2])
        cy, sy = math.cos(yaw), math.sin(yaw)
        rot = np.array([[cy, -sy], [sy, cy]])
        w = z @ rot.T                                            # (a, 2) rotated offsets
        g = np.zeros((a, 2, 3))
        g[:, 0, 0] = 1.0
        g[:, 1, 1] = 1.0
        g[:, 0, 2] = -w[:, 1]
        g[:, 1, 2] = w[:, 0]
        g2 = g.reshape(2 * a, 3)
        p = self.pbuf
        self.xbuf[n:n_new] = (self.xbuf[:2] + w).ravel()
        cross = g2 @ p[:3, :n]                                   # (2a, n)
        p[n:n_new, :n] = cross
        p[:n, n:n_new] = cross.T
        block = g2 @ p[:3, :3] @ g2.T
        rw = rot @ r @ rot.T                                     # (a, 2, 2)
        bi = 2 * np.arange(a)
        for i in range(2):
            for j in range(2):
                block[bi + i, bi + j] += rw[:, i, j]
        p[n:n_new, n:n_new] = 0.5 * (block + block.T)
        self.n = n_new

    def delete(self, lm: NDArray[np.int64]) -> NDArray[np.bool_]:
        """Remove landmarks ``lm`` (their rows and columns); returns the kept landmarks' mask
        (N,) as they were numbered before."""
        self.flush()
        n = self.n
        keep_lm = np.ones(self.n_landmarks, bool)
        keep_lm[lm] = False
        keep = np.concatenate([np.ones(self.vdim, bool), np.repeat(keep_lm, 2)])
        idx = np.flatnonzero(keep)
        x = self.xbuf[:n][idx]
        p = self.pbuf[:n, :n][np.ix_(idx, idx)]
        n_new = idx.size
        self.xbuf[:n_new] = x
        self.pbuf[:n_new, :n_new] = p
        self.n = n_new
        return keep_lm
