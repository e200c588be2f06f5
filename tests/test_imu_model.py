"""Simulated IMU: packets decode back to the true motion; bias/noise; faults; determinism."""

from __future__ import annotations

import math
import struct

import numpy as np
import pytest

from common.messages import GroundTruth
from orchestrator.config import AppConfig
from sensors.imu_protocol import ImuParser, crc16
from simulator.imu_model import GRAVITY_MPS2, ImuModel, ImuNoise

DT = 0.005
F32_TOL = 1e-5  # float32 rounding of values below ~20


def _f32(x: float) -> float:
    return struct.unpack("<f", struct.pack("<f", x))[0]


def _circle(n: int, speed: float = 6.0, radius: float = 15.0,
            accel: float = 0.0) -> list[GroundTruth]:
    """Truth of a car on a circle, speeding up at ``accel`` (m/s^2), with no side slip."""
    out = []
    for k in range(n):
        t = k * DT
        v = speed + accel * t
        out.append(GroundTruth(t, 0.0, 0.0, 0.0, v, 0.0, v / radius))
    return out


def test_noise_free_packets_decode_to_true_kinematics() -> None:
    config = AppConfig()
    model = ImuModel(config, np.random.default_rng(0))
    model.noise = False
    parser = ImuParser()
    got = []
    truths = _circle(400, accel=1.5)
    for truth in truths:
        for raw in model.poll(truth.timestamp_s, truth):
            assert raw.source == "imu" and len(raw.payload) == 38
            assert crc16(raw.payload[1:]) == 0
            got += parser.feed(raw.timestamp_s, raw.payload)
    assert len(got) == len(truths)
    assert not parser.rejects
    d = config.car.imu_x_m
    radius = 15.0
    for sample, truth in zip(got[2:], truths[2:], strict=True):
        v, r = truth.vx_mps, truth.yaw_rate_radps
        dr = 1.5 / radius
        assert sample.timestamp_s == pytest.approx(truth.timestamp_s, abs=1e-9)
        assert sample.accel_x_mps2 == pytest.approx(1.5 - r * r * d, abs=1e-4)
        assert sample.accel_y_mps2 == pytest.approx(r * v + dr * d, abs=1e-4)
        assert sample.accel_z_mps2 == _f32(GRAVITY_MPS2)
        assert sample.gyro_z_radps == pytest.approx(r, abs=F32_TOL)
        assert sample.gyro_x_radps == 0.0 and sample.gyro_y_radps == 0.0


def test_lever_arm_off_gives_origin_acceleration() -> None:
    config = AppConfig()
    model = ImuModel(config, np.random.default_rng(0), ImuNoise(lever_arm=False))
    model.noise = False
    truth = GroundTruth(0.0, 0.0, 0.0, 0.0, 10.0, 0.0, 0.5)
    sample = model.true_sample(0.0, truth)
    assert sample.accel_x_mps2 == pytest.approx(0.0)
    assert sample.accel_y_mps2 == pytest.approx(5.0)


def test_rate_is_200_hz_and_polls_catch_up() -> None:
    model = ImuModel(AppConfig(), np.random.default_rng(0))
    truth = GroundTruth(0.0, 0, 0, 0, 0, 0, 0)
    raws = model.poll(0.0, truth)
    raws += model.poll(0.1, GroundTruth(0.1, 0, 0, 0, 0, 0, 0))
    assert len(raws) == 21
    stamps = [r.timestamp_s for r in raws]
    assert stamps == sorted(stamps)
    assert np.allclose(np.diff(stamps), DT)


def test_noise_and_bias_statistics_at_rest() -> None:
    config = AppConfig()
    model = ImuModel(config, np.random.default_rng(4))
    parser = ImuParser()
    samples = []
    for k in range(2000):
        t = k * DT
        for raw in model.poll(t, GroundTruth(t, 0, 0, 0, 0, 0, 0)):
            samples += parser.feed(raw.timestamp_s, raw.payload)
    acc = np.array([[s.accel_x_mps2, s.accel_y_mps2, s.accel_z_mps2] for s in samples])
    gyro = np.array([[s.gyro_x_radps, s.gyro_y_radps, s.gyro_z_radps] for s in samples])
    imu = config.sim.imu
    # White noise level from successive differences (the bias hardly moves in 5 ms).
    assert np.allclose(np.diff(acc, axis=0).std(axis=0) / math.sqrt(2), imu.accel_sigma_mps2,
                       rtol=0.1)
    assert np.allclose(np.diff(gyro, axis=0).std(axis=0) / math.sqrt(2), imu.gyro_sigma_radps,
                       rtol=0.1)
    # Gravity in +z, biases within 4 sigma of their configured spread.
    assert acc[:, 2].mean() == pytest.approx(GRAVITY_MPS2, abs=4 * imu.accel_bias_sigma_mps2)
    assert np.all(np.abs(acc[:, :2].mean(axis=0)) < 4 * imu.accel_bias_sigma_mps2 + 0.01)
    assert np.all(np.abs(gyro.mean(axis=0)) < 4 * imu.gyro_bias_sigma_radps + 1e-3)


def test_nan_injection_is_rejected_by_the_parser() -> None:
    model = ImuModel(AppConfig(), np.random.default_rng(0))
    parser = ImuParser()
    model.inject_nan = True
    got = []
    for k in range(10):
        t = k * DT
        for raw in model.poll(t, GroundTruth(t, 0, 0, 0, 0, 0, 0)):
            got += parser.feed(raw.timestamp_s, raw.payload)
    assert got == []
    assert parser.rejects["nan"] == 10
    model.inject_nan = False
    t = 10 * DT
    raws = model.poll(t, GroundTruth(t, 0, 0, 0, 0, 0, 0))
    assert len(parser.feed(t, raws[0].payload)) == 1


def test_dropout_and_corruption() -> None:
    model = ImuModel(AppConfig(), np.random.default_rng(0))
    model.dropout = True
    assert model.poll(0.5, GroundTruth(0.5, 0, 0, 0, 0, 0, 0)) == []
    model.dropout = False
    model.corrupt_fraction = 1.0
    parser = ImuParser()
    got = []
    for k in range(101, 201):
        t = k * DT
        for raw in model.poll(t, GroundTruth(t, 0, 0, 0, 0, 0, 0)):
            got += parser.feed(raw.timestamp_s, raw.payload)
    got += parser.flush()
    assert got == []
    assert sum(parser.rejects.values()) >= 100


def test_same_seed_same_bytes() -> None:
    runs = []
    for _ in range(2):
        model = ImuModel(AppConfig(), np.random.default_rng(9))
        runs.append([r.payload for t in _circle(100) for r in model.poll(t.timestamp_s, t)])
    assert runs[0] == runs[1]


def test_uses_the_vehicle_model_acceleration_when_given() -> None:
    from common.messages import ActuatorCommand
    from simulator import vehicle as vehicle_mod

    config = AppConfig()
    vehicle = vehicle_mod.Vehicle(config.car)
    model = ImuModel(config, np.random.default_rng(0))
    model.noise = False
    parser = ImuParser()
    command = ActuatorCommand(0.0, 0.4, 0.0, 0.15)
    for k in range(1, 401):
        vehicle.step(command, DT)
        truth = vehicle.truth(k * DT)
        expected = vehicle.accel_at(config.car.imu_x_m, 0.0)
        for raw in model.poll(k * DT, truth, vehicle):
            for sample in parser.feed(raw.timestamp_s, raw.payload):
                if sample.timestamp_s < k * DT - 1e-9:
                    continue  # the packet due at t = 0, before the first step
                assert sample.accel_x_mps2 == pytest.approx(expected[0], abs=1e-4)
                assert sample.accel_y_mps2 == pytest.approx(expected[1], abs=1e-4)
                assert sample.gyro_z_radps == pytest.approx(truth.yaw_rate_radps, abs=1e-5)
    assert abs(vehicle.truth().yaw_rate_radps) > 0.1  # the car did turn
