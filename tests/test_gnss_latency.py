"""The GNSS latency estimated from a drive's own fixes and wheels (issue 44).

A synthetic drive (60 s: speeding up, braking, corners) with a known latency: fixes at 10 Hz
carry the position of ``L`` seconds before their time stamp, plus noise; the wheels (100 Hz,
CAN-quantised, noisy, 1.5 % off scale) and the gyro (biased) are on time. The estimate must be
within 0.01 s of ``L`` for ``L`` from 0.03 to 0.2 s, its sigma honest; a drive at a constant
speed cannot tell and says so.
"""

from __future__ import annotations

import numpy as np
import pytest

from mapper.gnss_latency import dead_reckoning, estimate_gnss_latency

DURATION_S = 60.0


def synthetic_drive(latency_s: float, seed: int = 3, constant_speed: bool = False,
                    position_noise_m: float = 0.02) -> dict[str, np.ndarray]:
    """Truth at 1 kHz; wheels and gyro at 100 Hz; fixes at 10 Hz, ``latency_s`` late."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, DURATION_S, 0.001)
    if constant_speed:
        v = np.full_like(t, 12.0)
    else:  # accelerate and brake every few seconds, 6..18 m/s
        v = 12.0 + 4.0 * np.sin(2 * np.pi * t / 9.0) + 2.0 * np.sin(2 * np.pi * t / 3.7 + 1.0)
    yaw_rate = 0.25 * np.sin(2 * np.pi * t / 13.0) + 0.15 * np.sign(np.sin(2 * np.pi * t / 7.0))
    truth = dead_reckoning(t, v, t, yaw_rate)
    odo_t = np.arange(0.5, DURATION_S - 0.5, 0.01)
    wheels = np.interp(odo_t, t, v) / 1.015 + rng.normal(0.0, 0.03, odo_t.size)
    wheels = np.round(wheels * 36.0) / 36.0  # CAN steps of 1/36 m/s
    gyro = np.interp(odo_t, t, yaw_rate) + 0.02 + rng.normal(0.0, 0.005, odo_t.size)
    fix_t = np.arange(1.0, DURATION_S - 1.0, 0.1)
    measured = fix_t - latency_s
    z = (np.interp(measured, t, truth.real) + 1j * np.interp(measured, t, truth.imag))
    walk = np.cumsum(rng.normal(0.0, 0.003, (fix_t.size, 2)), axis=0)  # a slow wander
    en = np.stack([z.real, z.imag], axis=1) + walk + rng.normal(0.0, position_noise_m,
                                                               (fix_t.size, 2))
    return {"fix_t_s": fix_t, "fix_en_m": en, "odo_t_s": odo_t, "speed_mps": wheels,
            "yaw_rate_t_s": odo_t, "yaw_rate_radps": gyro}


@pytest.mark.parametrize("latency_s", [0.03, 0.06, 0.1, 0.15, 0.2])
def test_known_latency_recovered_within_10_ms(latency_s: float) -> None:
    drive = synthetic_drive(latency_s)
    estimate = estimate_gnss_latency(**drive)
    assert estimate is not None
    assert abs(estimate.latency_s - latency_s) <= 0.01, estimate
    assert 0.0 < estimate.sigma_s < 0.01
    assert abs(estimate.latency_s - latency_s) <= 4.0 * estimate.sigma_s + 0.002
    assert estimate.speed_scale == pytest.approx(1.015, abs=0.005)


def test_noisier_fixes_still_within_10_ms() -> None:
    estimate = estimate_gnss_latency(**synthetic_drive(0.12, seed=11, position_noise_m=0.05))
    assert estimate is not None and abs(estimate.latency_s - 0.12) <= 0.01, estimate


def test_without_the_gyro_on_a_curved_drive_still_close() -> None:
    drive = synthetic_drive(0.08, seed=5)
    drive.pop("yaw_rate_t_s"), drive.pop("yaw_rate_radps")
    estimate = estimate_gnss_latency(**drive)
    assert estimate is not None and abs(estimate.latency_s - 0.08) <= 0.015, estimate


def test_constant_speed_cannot_tell() -> None:
    assert estimate_gnss_latency(**synthetic_drive(0.1, constant_speed=True)) is None


def test_too_few_fixes_cannot_tell() -> None:
    drive = synthetic_drive(0.1)
    drive["fix_t_s"], drive["fix_en_m"] = drive["fix_t_s"][:20], drive["fix_en_m"][:20]
    assert estimate_gnss_latency(**drive) is None
