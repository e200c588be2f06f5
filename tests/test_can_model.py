"""The simulated CAN bus decodes with cantools back to the true values within quantisation."""

from __future__ import annotations

import math

import cantools
import numpy as np
import pytest

from common.messages import GroundTruth, RemoteStop
from orchestrator.config import AppConfig
from sensors.can_codec import (
    DEFAULT_DBC_PATH,
    RES_STATE_ID,
    STEERING_ANGLE_ID,
    WHEEL_SPEEDS_ID,
    CanCodec,
)
from simulator.can_model import CanModel

DB = cantools.database.load_file(str(DEFAULT_DBC_PATH))


def _truth(t_s: float, vx: float = 10.0, r: float = 0.5, steer: float = 0.1) -> GroundTruth:
    return GroundTruth(t_s, 0.0, 0.0, 0.0, vx, 0.0, r, steer)


def _noiseless(seed: int = 1) -> CanModel:
    return CanModel(AppConfig(), np.random.default_rng(seed), wheel_slip_sigma=0.0,
                    wheel_noise_mps=0.0, steer_noise_rad=0.0)


def test_rates_and_time_order() -> None:
    model = _noiseless()
    frames = []
    for k in range(0, 201):  # 1 s at a 200 Hz physics step
        frames += model.poll(k * 0.005, _truth(k * 0.005))
    ids = [f.arbitration_id for f in frames]
    assert ids.count(WHEEL_SPEEDS_ID) == 101
    assert ids.count(STEERING_ANGLE_ID) == 101
    assert ids.count(RES_STATE_ID) == 11
    times = [f.timestamp_s for f in frames]
    assert times == sorted(times)


def test_frames_decode_to_true_values_within_quantisation() -> None:
    model = _noiseless()
    car = AppConfig().car
    truth = _truth(0.0, vx=12.0, r=0.8, steer=0.15)
    true_ws = model.true_wheel_speeds(truth)
    # rigid-body check: rear wheels differ by yaw rate x track width, mean = vx
    assert true_ws[3] - true_ws[2] == pytest.approx(0.8 * car.track_width_m)
    assert 0.5 * (true_ws[2] + true_ws[3]) == pytest.approx(12.0)
    frames = model.poll(0.0, truth)
    by_id = {f.arbitration_id: f for f in frames}
    ws = DB.decode_message(WHEEL_SPEEDS_ID, by_id[WHEEL_SPEEDS_ID].data)
    for name, value in zip(("FL", "FR", "RL", "RR"), true_ws, strict=True):
        assert ws[f"WHEEL_SPEED_{name}"] == pytest.approx(value, abs=0.0005 + 1e-9)
    steer = DB.decode_message(STEERING_ANGLE_ID, by_id[STEERING_ANGLE_ID].data)
    assert steer["STEERING_ANGLE"] == pytest.approx(0.15, abs=0.00005 + 1e-9)
    res = DB.decode_message(RES_STATE_ID, by_id[RES_STATE_ID].data)
    assert res["RES_EMERGENCY"] == 0 and res["RES_GO"] == 1


def test_noise_is_seeded_and_plausible() -> None:
    def run(seed: int) -> list[bytes]:
        model = CanModel(AppConfig(), np.random.default_rng(seed))
        out = []
        for k in range(1, 101):
            out += [f.data for f in model.poll(k * 0.01, _truth(k * 0.01, vx=10.0, r=0.0,
                                                                 steer=0.0))]
        return out

    assert run(7) == run(7)
    assert run(7) != run(8)
    codec = CanCodec()
    model = CanModel(AppConfig(), np.random.default_rng(3))
    speeds = []
    for k in range(1, 501):
        for frame in model.poll(k * 0.01, _truth(k * 0.01, vx=10.0, r=0.0, steer=0.0)):
            for reading in codec.decode(frame):
                if hasattr(reading, "rear_left_mps"):
                    speeds.append(reading.rear_left_mps)
    speeds_arr = np.asarray(speeds)
    # 1 % slip sigma on 10 m/s plus 2 cm/s: sigma ~ 0.102 m/s
    assert np.mean(speeds_arr) == pytest.approx(10.0, abs=0.03)
    assert np.std(speeds_arr) == pytest.approx(math.hypot(0.1, 0.02), rel=0.2)


def test_standing_car_reads_zero() -> None:
    model = CanModel(AppConfig(), np.random.default_rng(1))
    codec = CanCodec()
    readings = [r for f in model.poll(0.0, _truth(0.0, vx=0.0, r=0.0, steer=0.0))
                for r in codec.decode(f)]
    ws = [r for r in readings if hasattr(r, "mean_mps")][0]
    assert ws.mean_mps == 0.0


def test_estop_and_garbage_faults() -> None:
    model = _noiseless()
    codec = CanCodec()
    model.poll(0.0, _truth(0.0))
    model.set_res(emergency=True, go=False)
    model.garbage = True
    frames = []
    for k in range(1, 101):
        frames += model.poll(k * 0.01, _truth(k * 0.01))
    readings = [r for f in frames for r in codec.decode(f)]
    res = [r for r in readings if isinstance(r, RemoteStop)]
    assert len(res) == 10 and all(r.emergency and not r.go for r in res)
    assert codec.rejects["unknown_id"] > 20
    assert codec.rejects["bad_length"] > 20
    # the good frames still decode: one wheel-speed reading per 10 ms tick
    assert sum(1 for r in readings if hasattr(r, "mean_mps")) == 100
