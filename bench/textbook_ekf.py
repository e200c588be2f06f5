"""The textbook EKF-SLAM update, the reference ``bench slam`` times ours against (and the
tests check ours equals).

A full dense ``H`` (2a, n), ``S = H P H^T + R``, an explicit ``inv(S)``, ``K = P H^T S^-1`` and
a full n x n covariance update: ``form="joseph"`` is filterpy's ``ExtendedKalmanFilter.update``
(``(I - K H) P (I - K H)^T + K R K^T``, two n^3 products), ``form="simple"`` is PythonRobotics'
``ekf_slam.py`` (``(I - K H) P``, one n^3 product; PythonRobotics applies it once per detection,
here once per sweep). Same models as :mod:`mapper.slam.models`.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from common.conventions import wrap_angle
from mapper.slam.models import POSE_DIM, observation_model

FloatArray = NDArray[np.float64]


def textbook_update(x: FloatArray, p: FloatArray, z: FloatArray, r: FloatArray,
                    landmarks: NDArray[np.int64], form: str = "joseph"
                    ) -> tuple[FloatArray, FloatArray]:
    """One update of state ``x`` (n,) and ``p`` (n, n) with detections ``z`` (a, 2) of
    ``landmarks`` (a,) and noise ``r`` (a, 2, 2). Returns new (x, P)."""
    n = x.size
    a = landmarks.size
    lm_xy = x[POSE_DIM:].reshape(-1, 2)[landmarks]
    zhat, hp, hl = observation_model(x[:3], lm_xy)
    h = np.zeros((2 * a, n))
    rr = np.zeros((2 * a, 2 * a))
    for i, j in enumerate(landmarks):
        h[2 * i: 2 * i + 2, :3] = hp[i]
        c = POSE_DIM + 2 * int(j)
        h[2 * i: 2 * i + 2, c: c + 2] = hl
        rr[2 * i: 2 * i + 2, 2 * i: 2 * i + 2] = r[i]
    y = (z - zhat).ravel()
    s = h @ p @ h.T + rr
    k = p @ h.T @ np.linalg.inv(s)
    x_new = x + k @ y
    x_new[2] = wrap_angle(float(x_new[2]))
    i_kh = np.eye(n) - k @ h
    if form == "simple":
        return x_new, i_kh @ p
    return x_new, i_kh @ p @ i_kh.T + k @ rr @ k.T
