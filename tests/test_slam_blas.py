"""The EKF SLAM's in-place BLAS update: ``dsyrk`` on a strided view, the lower triangle as the
truth between updates, and the lazy mirror. The filter must give the same estimate whether or
not anyone reads the whole ``P`` between updates, and the same as the plain numpy update."""

from __future__ import annotations

import math

import numpy as np
import pytest

from common.car import CarConfig
from common.messages import ConeDetection, ConeSize, ImuSample, WheelSpeeds
from mapper.config import MapperConfig
from mapper.slam import ekf as slam_ekf
from mapper.slam.blas import have_syrk, limit_blas_threads, mirror_lower, syrk_lower_inplace
from mapper.slam.ekf_slam import EkfSlam

limit_blas_threads(1)


@pytest.mark.parametrize(("n", "cap", "k"), [(605, 605, 40), (300, 544, 13), (9, 136, 2),
                                             (1, 8, 3)])
def test_syrk_lower_inplace_on_a_view_with_capacity(n: int, cap: int, k: int) -> None:
    if not have_syrk():
        pytest.skip("no bundled cblas_dsyrk")
    rng = np.random.default_rng(n)
    buf = np.full((cap, cap), 7.0)
    b = rng.normal(size=(n, n))
    p = b @ b.T
    buf[:n, :n] = p
    v = np.asfortranarray(rng.normal(size=(n, k)))
    view = buf[:n, :n]
    assert syrk_lower_inplace(view, v)
    ref = p - v @ v.T
    low = np.tril_indices(n)
    assert np.max(np.abs(view[low] - ref[low])) < 1e-12 * max(1.0, float(np.max(np.abs(ref))))
    up = np.triu_indices(n, 1)
    assert np.array_equal(view[up], p[up])                  # the upper triangle untouched
    assert np.all(buf[n:, :] == 7.0) and np.all(buf[:, n:] == 7.0)   # nor the capacity
    mirror_lower(view)
    assert np.array_equal(view, view.T)
    assert np.max(np.abs(view - ref)) < 1e-12 * max(1.0, float(np.max(np.abs(ref))))


def test_syrk_refuses_layouts_blas_cannot_address() -> None:
    c = np.zeros((6, 6))
    v = np.ones((6, 2))
    assert not syrk_lower_inplace(c[:3, ::2], v[:3])          # column stride 2
    assert not syrk_lower_inplace(np.zeros((4, 4), np.float32), np.ones((4, 1)))
    assert np.all(c == 0.0)


def _drive(slam: EkfSlam, read_p_every_step: bool) -> None:
    """A straight drive at 5 m/s past cones every 4 m on both sides: IMU at 100 Hz, wheels at
    50 Hz, GPS at 10 Hz, LiDAR sweeps at 10 Hz (landmarks promoted, associated), then a
    landmark deleted and two merged, and more driving."""
    rng = np.random.default_rng(3)
    cones = np.array([(x, y) for x in np.arange(4.0, 60.0, 4.0) for y in (-2.0, 2.0)])
    speed = 5.0
    slam.load_state(np.array([0.0, 0.0, 0.0, speed, 0.0]), np.diag([1e-4, 1e-4, 1e-5, 1e-2,
                                                                    1e-2]))

    def step(i: int) -> None:
        t = 0.01 * i
        slam.predict(ImuSample(t, rng.normal(0, 0.05), rng.normal(0, 0.05), 9.81, 0.0, 0.0,
                               rng.normal(0, 0.002)))
        if i % 2 == 0:
            v = speed + rng.normal(0, 0.02)
            slam.update_odometry(WheelSpeeds(t, v, v, v, v), None)
        if i % 10 == 5:
            slam.update_gps_xy(np.array([speed * t, 0.0]) + rng.normal(0, 0.5, 2),
                               np.eye(2) * 0.25, t)
        if i % 10 == 0:
            rel = cones - np.array([speed * t, 0.0])
            seen = rel[(rel[:, 0] > 1.0) & (rel[:, 0] < 15.0)]
            slam.update_cones([ConeDetection(t, float(x) + rng.normal(0, 0.02),
                                             float(y) + rng.normal(0, 0.02), size=ConeSize.SMALL)
                               for x, y in seen], t)
        if read_p_every_step:
            p = slam.P
            assert np.array_equal(p, p.T)

    for i in range(1, 300):
        step(i)
    assert slam.n_landmarks > 10
    slam.delete_landmarks(np.array([1]))
    slam.merge_landmarks(np.array([0]), np.array([2]))
    for i in range(300, 500):
        step(i)


def test_lazy_mirror_gives_the_same_filter_as_reading_p_every_step() -> None:
    a = EkfSlam(MapperConfig(), CarConfig())
    b = EkfSlam(MapperConfig(), CarConfig())
    _drive(a, read_p_every_step=True)
    _drive(b, read_p_every_step=False)
    ma, mb = a.cone_map(), b.cone_map()
    assert np.array_equal(ma.ids, mb.ids)
    assert np.allclose(ma.covariance, mb.covariance, rtol=1e-9, atol=1e-15)
    assert np.allclose(a.x, b.x, rtol=0.0, atol=1e-9)
    pa, pb = a.P, b.P
    assert np.array_equal(pb, pb.T)
    assert np.max(np.abs(pa - pb)) <= 1e-9 * float(np.max(np.abs(pa)))
    assert np.linalg.eigvalsh(pb).min() > 0.0
    assert a.pose().covariance is not None
    assert np.allclose(a.pose().covariance, b.pose().covariance, rtol=1e-9, atol=1e-15)


def test_blas_update_equals_the_numpy_fallback(monkeypatch: pytest.MonkeyPatch) -> None:
    a = EkfSlam(MapperConfig(), CarConfig())
    _drive(a, read_p_every_step=False)
    monkeypatch.setattr(slam_ekf, "syrk_lower_inplace", lambda c, v, alpha=-1.0: False)
    b = EkfSlam(MapperConfig(), CarConfig())
    _drive(b, read_p_every_step=False)
    assert a.n_landmarks == b.n_landmarks
    assert np.allclose(a.x, b.x, rtol=0.0, atol=1e-8)
    pa, pb = a.P, b.P
    assert np.array_equal(pa, pa.T) and np.array_equal(pb, pb.T)
    assert np.max(np.abs(pa - pb)) <= 1e-8 * float(np.max(np.abs(pa)))
    assert math.isfinite(float(np.max(np.abs(pa))))
