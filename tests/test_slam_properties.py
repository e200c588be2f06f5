"""Property tests of the EKF SLAM: P stays symmetric positive definite over long random runs;
the analytic Jacobians match numerical ones."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from common.car import CarConfig
from common.messages import ConeDetection, ConeSize, ImuSample, WheelSpeeds
from mapper.config import MapperConfig
from mapper.slam.blas import limit_blas_threads
from mapper.slam.ekf_slam import EkfSlam
from mapper.slam.models import motion_model, observation_model

limit_blas_threads(1)

finite = {"allow_nan": False, "allow_infinity": False}


def _numerical_jacobian(f, x: np.ndarray, eps: float = 1e-6) -> np.ndarray:  # type: ignore[no-untyped-def]
    cols = []
    for i in range(x.size):
        d = np.zeros_like(x)
        d[i] = eps
        cols.append((f(x + d) - f(x - d)) / (2 * eps))
    return np.stack(cols, axis=-1)


@settings(max_examples=60, deadline=None)
@given(
    pose=st.tuples(st.floats(-50, 50, **finite), st.floats(-50, 50, **finite),
                   st.floats(-3.0, 3.0, **finite), st.floats(-10, 10, **finite),
                   st.floats(-10, 10, **finite)),
    gyro=st.floats(-2, 2, **finite), ax=st.floats(-10, 10, **finite),
    ay=st.floats(-15, 15, **finite), dt=st.floats(0.001, 0.05, **finite),
    seed_mode=st.booleans(),
)
def test_motion_jacobians_match_numerical(pose: tuple[float, ...], gyro: float, ax: float,
                                          ay: float, dt: float, seed_mode: bool) -> None:
    x = np.array(pose)
    k = 0.5 * dt * dt if seed_mode else 0.5 * dt
    _, f, g = motion_model(x, gyro, ax, ay, dt, k)

    def fx(v: np.ndarray) -> np.ndarray:
        out = motion_model(v, gyro, ax, ay, dt, k)[0]
        out[2] = v[2] + dt * gyro   # unwrapped, for differencing
        return out

    def fu(u: np.ndarray) -> np.ndarray:
        out = motion_model(x, u[0], u[1], u[2], dt, k)[0]
        out[2] = x[2] + dt * u[0]
        return out

    assert np.max(np.abs(f - _numerical_jacobian(fx, x))) < 1e-6
    assert np.max(np.abs(g - _numerical_jacobian(fu, np.array([gyro, ax, ay])))) < 1e-6


@settings(max_examples=60, deadline=None)
@given(
    pose=st.tuples(st.floats(-50, 50, **finite), st.floats(-50, 50, **finite),
                   st.floats(-3.1, 3.1, **finite)),
    lm=st.tuples(st.floats(-60, 60, **finite), st.floats(-60, 60, **finite)),
)
def test_observation_jacobians_match_numerical(pose: tuple[float, float, float],
                                               lm: tuple[float, float]) -> None:
    x = np.array(pose)
    lxy = np.array([lm])
    _, hp, hl = observation_model(x, lxy)
    num_p = _numerical_jacobian(lambda v: observation_model(v, lxy)[0][0], x)
    num_l = _numerical_jacobian(lambda v: observation_model(x, v[None, :])[0][0], lxy[0])
    assert np.max(np.abs(hp[0] - num_p)) < 1e-6
    assert np.max(np.abs(hl - num_l)) < 1e-6


_step = st.one_of(
    st.tuples(st.just("imu"), st.floats(-1.5, 1.5, **finite), st.floats(-8, 8, **finite),
              st.floats(-12, 12, **finite)),
    st.tuples(st.just("wheels"), st.floats(0, 20, **finite)),
    st.tuples(st.just("gps"), st.floats(-30, 30, **finite), st.floats(-30, 30, **finite)),
    st.tuples(st.just("cones"), st.lists(st.tuples(st.floats(1, 20, **finite),
                                                   st.floats(-12, 12, **finite)),
                                         min_size=0, max_size=12)),
)


@settings(max_examples=25, deadline=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(steps=st.lists(_step, min_size=50, max_size=250), seed=st.integers(0, 1000))
def test_covariance_stays_symmetric_positive_definite(steps: list[tuple], seed: int) -> None:
    """Random IMU, odometry, GPS and cone sweeps (each sweep repeated so the preliminary list
    promotes landmarks) in any order: P stays symmetric and positive definite."""
    rng = np.random.default_rng(seed)
    slam = EkfSlam(MapperConfig(), CarConfig())
    t = 0.0
    for step in steps:
        t += 0.01
        kind = step[0]
        if kind == "imu":
            slam.predict(ImuSample(t, step[2], step[3], 9.81, 0.0, 0.0, step[1]))
        elif kind == "wheels":
            v = step[1]
            slam.update_odometry(WheelSpeeds(t, v, v, v, v), None)
        elif kind == "gps":
            slam.update_gps_xy(np.array([step[1], step[2]]), np.eye(2) * 6.25, t)
        else:
            cones = [ConeDetection(t, x + rng.normal(0, 0.02), y + rng.normal(0, 0.02),
                                   size=ConeSize.SMALL) for x, y in step[1]]
            slam.update_cones(cones, t)
            t += 0.01
            slam.update_cones([ConeDetection(t, c.x_m, c.y_m) for c in cones], t)
        p = slam.P
        assert np.all(np.isfinite(p)) and np.all(np.isfinite(slam.x))
        assert np.max(np.abs(p - p.T)) <= 1e-12 * max(1.0, float(np.max(np.abs(p))))
    p = slam.P
    assert np.linalg.eigvalsh(0.5 * (p + p.T)).min() > 0.0
    assert -math.pi < slam.x[2] <= math.pi
