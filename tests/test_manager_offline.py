"""The SensorManager offline (simulation, replay): the same parsers, no threads, the run's clock."""

from __future__ import annotations

import threading

import numpy as np
import pytest

from common.clock import SimClock
from common.messages import (
    ActuatorCommand,
    AsState,
    CanFrame,
    GpsFix,
    GroundTruth,
    ImuSample,
    RawBytes,
    RemoteStop,
    SteeringAngle,
    WheelSpeeds,
)
from orchestrator.config import AppConfig
from sensors.can_codec import CanCodec
from sensors.imu_protocol import encode_imu_packet
from sensors.manager import SensorManager
from sensors.nmea_framing import with_checksum
from simulator.can_model import CanModel


def gga(k: int) -> bytes:
    return with_checksum(
        f"GPGGA,1200{k % 60:02d}.{k % 10}0,4919.6140,N,00833.9240,E,1,08,0.9,100.0,M,47.0,M,,")


def offline_config() -> AppConfig:
    config = AppConfig()
    config.sensors.camera.enabled = False
    config.sensors.lidar.enabled = False
    return config


OFFLINE = offline_config()


def sim_stream(duration_s: float, seed: int = 1) -> list[RawBytes | CanFrame]:
    """What a simulated car sends in ``duration_s``: GPS 10 Hz, IMU 200 Hz, CAN, in time order."""
    config = offline_config()
    can_model = CanModel(config, np.random.default_rng(seed))
    out: list[RawBytes | CanFrame] = []
    steps = int(round(duration_s * 200))
    for k in range(steps + 1):
        t = k * 0.005
        truth = GroundTruth(t, 2.0 * t, 0.0, 0.0, 2.0, 0.0, 0.0, 0.05)
        out += can_model.poll(t, truth)
        if k > 0:
            out.append(RawBytes(t, "imu", encode_imu_packet(
                ImuSample(t, 0.0, 0.0, 9.81, 0.0, 0.0, 0.0))))
        if k % 20 == 0:
            out.append(RawBytes(t, "gps", gga(k // 20)))
    out.sort(key=lambda u: u.timestamp_s)
    return out


def test_ingest_take_in_time_order_with_latest_and_no_threads() -> None:
    config = offline_config()
    clock = SimClock()
    threads_before = threading.active_count()
    manager = SensorManager(config.sensors, config.car, clock)
    stream = sim_stream(1.0)
    # fed in two halves, as the simulation loop does step by step
    manager.ingest(stream[: len(stream) // 2])
    first = manager.take()
    manager.ingest(stream[len(stream) // 2:])
    second = manager.take()
    assert threading.active_count() == threads_before
    assert manager.receivers == {}
    raw = first.raw + second.raw
    assert raw == stream
    readings = first.readings + second.readings
    assert [r.timestamp_s for r in first.readings] == sorted(r.timestamp_s for r in first.readings)
    assert [r.timestamp_s for r in second.readings] == sorted(
        r.timestamp_s for r in second.readings)
    counts = {cls: sum(isinstance(r, cls) for r in readings)
              for cls in (GpsFix, ImuSample, WheelSpeeds, SteeringAngle, RemoteStop)}
    assert counts == {GpsFix: 11, ImuSample: 200, WheelSpeeds: 101, SteeringAngle: 101,
                      RemoteStop: 11}
    assert set(second.latest) == {"gps", "imu", "wheel_speeds", "steering", "res"}
    assert second.latest["wheel_speeds"].timestamp_s == pytest.approx(1.0)
    assert second.latest["steering"].angle_rad == pytest.approx(0.05, abs=0.01)
    assert manager.take().readings == []


def test_health_rate_age_and_staleness_on_the_run_clock() -> None:
    config = offline_config()
    manager = SensorManager(config.sensors, config.car, SimClock())
    manager.ingest(sim_stream(3.0))
    manager.take()
    health = {s.source: s for s in manager.health(3.0).sources}
    assert set(health) == {"gps", "imu", "can", "res"}
    assert health["imu"].rate_hz == pytest.approx(200.0, rel=0.01)
    assert health["gps"].rate_hz == pytest.approx(10.0, rel=0.06)
    # wheel speeds + steering at 100 Hz each + RES at 10 Hz
    assert health["can"].rate_hz == pytest.approx(210.0, rel=0.01)
    assert health["res"].rate_hz == pytest.approx(10.0, rel=0.06)
    for s in health.values():
        assert s.alive and not s.stale and s.errors == 0
        assert s.age_s == pytest.approx(0.0, abs=1e-9)
    # silence: each source turns stale once its own timeout has passed
    later = {s.source: s for s in manager.health(3.0 + 0.2).sources}
    assert later["imu"].stale  # timeout 0.1 s
    assert later["can"].stale  # timeout 0.1 s
    assert not later["gps"].stale  # timeout 0.5 s
    assert not later["res"].stale  # timeout 0.5 s
    assert later["imu"].age_s == pytest.approx(0.2)
    much_later = manager.health(10.0)
    assert set(much_later.stale_sources()) == {"gps", "imu", "can", "res"}


def test_res_goes_stale_alone_while_wheel_speeds_keep_coming() -> None:
    manager = SensorManager(OFFLINE.sensors, OFFLINE.car, SimClock())
    codec = CanCodec()
    manager.ingest([codec.encode_res(RemoteStop(0.0, False, True))])
    manager.ingest([codec.encode_wheel_speeds(WheelSpeeds(0.01 * k, 1, 1, 1, 1))
                    for k in range(1, 101)])
    health = {s.source: s for s in manager.health(1.0).sources}
    assert not health["can"].stale
    assert health["res"].stale and health["res"].age_s == pytest.approx(1.0)
    assert manager.health(1.0).stale_sources() == ("gps", "imu", "res")


def test_bad_input_is_counted_never_raised() -> None:
    manager = SensorManager(OFFLINE.sensors, OFFLINE.car, SimClock())
    model = CanModel(offline_config(), np.random.default_rng(5))
    model.garbage = True
    frames = []
    for k in range(50):
        frames += model.poll(0.01 * k, GroundTruth(0.01 * k, 0, 0, 0, 3.0, 0, 0, 0))
    manager.ingest(frames)
    manager.ingest([RawBytes(0.6, "gps", b"\x00\xff binary \xfe\r\n"),
                    RawBytes(0.6, "imu", b"\xfa\x01\x02"),
                    RawBytes(0.6, "lidar", b"\x00" * 1206),  # LiDAR is not enabled here
                    RawBytes(0.6, "nonsense", b"?")])
    batch = manager.take()
    assert sum(isinstance(r, WheelSpeeds) for r in batch.readings) == 50
    health = {s.source: s for s in manager.health(0.6).sources}
    can_rejects = dict(health["can"].rejects)
    assert can_rejects["unknown_id"] > 0 and can_rejects["bad_length"] > 0
    assert dict(health["gps"].rejects)
    assert manager.rejects["unknown_source"] == 2
    assert all(s.errors == 0 for s in health.values())


def test_same_stream_gives_the_same_readings() -> None:
    stream = sim_stream(0.5, seed=3)
    outs = []
    for _ in range(2):
        manager = SensorManager(OFFLINE.sensors, OFFLINE.car, SimClock())
        manager.ingest(stream)
        outs.append(manager.take().readings)
    assert outs[0] == outs[1]


def test_send_command_offline_returns_the_frame() -> None:
    manager = SensorManager(OFFLINE.sensors, OFFLINE.car, SimClock())
    frame = manager.send_command(ActuatorCommand(2.0, 0.0, 1.0, 0.1, AsState.EMERGENCY))
    cmd = CanCodec().decode_command(frame)
    assert cmd is not None and cmd.brake == 1.0 and cmd.state is AsState.EMERGENCY
    assert frame.timestamp_s == 2.0


def test_can_model_with_the_simulated_vehicle() -> None:
    from simulator import vehicle as vehicle_mod
    config = offline_config()
    vehicle = vehicle_mod.Vehicle(config.car)
    cmd = ActuatorCommand(0.0, 0.5, 0.0, 0.1)
    for _ in range(400):
        vehicle.step(cmd, 0.005)
    model = CanModel(config, np.random.default_rng(1), wheel_slip_sigma=0.0,
                     wheel_noise_mps=0.0, steer_noise_rad=0.0)
    truth = vehicle.truth(2.0)
    frames = model.poll(2.0, truth, vehicle)
    readings = [r for f in frames for r in CanCodec().decode(f)]
    ws = next(r for r in readings if isinstance(r, WheelSpeeds))
    expected = vehicle.wheel_speeds_mps()
    got = (ws.front_left_mps, ws.front_right_mps, ws.rear_left_mps, ws.rear_right_mps)
    assert got == pytest.approx(expected, abs=0.0005 + 1e-9)
    assert min(got) > 1.0
