"""The SensorManager live: every receiver on a real transport at once (GPS and IMU on ptys, CAN
as slcan on a pty, LiDAR and camera on loopback UDP); commands out on CAN; one stop deadline."""

from __future__ import annotations

import collections
import os
import select
import socket
import time
import tty
from collections.abc import Callable
from typing import Any

import pytest

from common.clock import RealClock
from common.messages import (
    ActuatorCommand,
    AsState,
    CanFrame,
    GpsFix,
    ImuSample,
    RawBytes,
    RemoteStop,
    WheelSpeeds,
)
from orchestrator.config import AppConfig
from sensors.can_codec import AS_COMMAND_ID, CanCodec
from sensors.imu_protocol import encode_imu_packet
from sensors.manager import SensorManager
from sensors.nmea_framing import with_checksum


def make_pty() -> tuple[int, int, str]:
    master, slave = os.openpty()
    tty.setraw(slave)
    return master, slave, os.ttyname(slave)


def wait_for(condition: Callable[[], bool], timeout_s: float = 5.0) -> bool:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if condition():
            return True
        time.sleep(0.02)
    return condition()


def gga(k: int) -> bytes:
    return with_checksum(
        f"GPGGA,1200{k % 60:02d}.00,4919.6140,N,00833.9240,E,1,08,0.9,100.0,M,47.0,M,,")


def slcan_line(frame: CanFrame) -> bytes:
    return f"t{frame.arbitration_id:03X}{len(frame.data)}{frame.data.hex().upper()}\r".encode()


class PlainCameraParser:
    """Stand-in until sensors.camera_codec exists: b'CAM' datagrams are readings."""

    source = "camera"

    def __init__(self) -> None:
        self.rejects: collections.Counter[str] = collections.Counter()

    def feed(self, timestamp_s: float, payload: bytes) -> list[RawBytes]:
        if payload.startswith(b"CAM"):
            return [RawBytes(timestamp_s, "camera", payload)]
        self.rejects["garbage"] += 1
        return []


@pytest.fixture
def ptys():
    made = [make_pty() for _ in range(3)]
    yield made
    for master, slave, _ in made:
        for fd in (master, slave):
            try:
                os.close(fd)
            except OSError:
                pass


def live_config(ptys: list[tuple[int, int, str]]) -> AppConfig:
    config = AppConfig()
    s = config.sensors
    s.gps.port, s.imu.port = ptys[0][2], ptys[1][2]
    s.can.interface, s.can.channel, s.can.bitrate = "slcan", ptys[2][2], 500000
    s.lidar.host = s.camera.host = "127.0.0.1"
    s.lidar.port = s.camera.port = 0
    for section in (s.gps, s.imu, s.can, s.lidar, s.camera):
        section.read_timeout_s = 0.02
    s.reconnect_min_s, s.reconnect_max_s = 0.02, 0.1
    s.stop_timeout_s = 1.0
    return config


def test_every_receiver_live_take_health_command_and_prompt_stop(ptys) -> None:
    config = live_config(ptys)
    clock = RealClock()
    try:
        from sensors.camera_codec import CameraParser, encode_camera_cones  # noqa: F401
        parsers: dict[str, Any] = {}
        camera_payload = None
    except ImportError:
        parsers = {"camera": PlainCameraParser()}
        camera_payload = b"CAM frame"
    manager = SensorManager(config.sensors, config.car, clock, parsers=parsers)
    assert manager.enabled == ("gps", "imu", "can", "lidar", "camera")
    health = manager.health(clock.now_s())
    assert all(s.stale for s in health.sources)  # nothing heard yet
    manager.start()
    try:
        assert manager.wait_connected(5.0)
        names = {t.name for t in __import__("threading").enumerate()}
        for source in ("gps", "imu", "can", "lidar", "camera"):
            assert f"receiver-{source}" in names
        (gps_m, _, _), (imu_m, _, _), (can_m, _, _) = ptys
        os.write(gps_m, gga(1) + gga(2))
        os.write(imu_m, b"".join(encode_imu_packet(ImuSample(0.005 * k, 0, 0, 9.81, 0, 0, 0.1))
                                 for k in range(1, 11)))
        codec = CanCodec()
        os.write(can_m, slcan_line(codec.encode_wheel_speeds(WheelSpeeds(0, 5, 5, 5, 5)))
                 + slcan_line(codec.encode_res(RemoteStop(0, False, True)))
                 + slcan_line(CanFrame(0, 0x7AB, b"\x01")))
        lidar_addr = manager.receivers["lidar"].bound_address  # type: ignore[attr-defined]
        camera_addr = manager.receivers["camera"].bound_address  # type: ignore[attr-defined]
        if camera_payload is None:
            from common.messages import CameraCones, ConeDetection
            from sensors.camera_codec import encode_camera_cones
            camera_payload = encode_camera_cones(
                CameraCones(0.0, (ConeDetection(0.0, 4.0, 1.0),), frame_id=1))
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
            sock.sendto(b"\x00" * 1206, ("127.0.0.1", lidar_addr[1]))  # garbage packet
            sock.sendto(b"short", ("127.0.0.1", lidar_addr[1]))
            sock.sendto(camera_payload, ("127.0.0.1", camera_addr[1]))

        got: list[Any] = []
        raw: list[Any] = []

        def collect() -> bool:
            batch = manager.take()
            stamps = [r.timestamp_s for r in batch.readings]
            assert stamps == sorted(stamps)  # each batch in time order
            got.extend(batch.readings)
            raw.extend(batch.raw)
            kinds = {type(r) for r in got}
            return {GpsFix, ImuSample, WheelSpeeds, RemoteStop} <= kinds and len(raw) >= 9

        ok = wait_for(collect)
        assert ok, (collections.Counter(type(r).__name__ for r in got), len(raw),
                    {k: r.stats(clock.now_s()) for k, r in manager.receivers.items()})
        batch = manager.take()
        assert batch.readings == [] and batch.raw == []
        assert {"gps", "imu", "wheel_speeds", "res"} <= set(batch.latest)
        assert isinstance(batch.latest["res"], RemoteStop) and batch.latest["res"].go
        assert sum(isinstance(r, ImuSample) for r in got) == 10
        now = clock.now_s()
        health = {s.source: s for s in manager.health(now).sources}
        assert set(health) == {"gps", "imu", "can", "res", "lidar", "camera"}
        for source in ("gps", "imu", "can", "res"):
            assert health[source].alive and health[source].age_s < 10.0
        assert dict(health["can"].rejects) == {"unknown_id": 1}
        assert sum(dict(health["lidar"].rejects).values()) == 2
        assert health["lidar"].alive and health["lidar"].stale  # no sweep yet
        assert health["lidar"].errors == 0

        # a silent source turns stale once its timeout passes
        assert wait_for(lambda: "imu" in manager.health(clock.now_s()).stale_sources())

        # the actuator command goes out on the bus
        os.read(can_m, 4096)  # adapter set-up commands
        cmd = ActuatorCommand(clock.now_s(), 0.3, 0.0, 0.05, AsState.DRIVING)
        frame = manager.send_command(cmd)
        assert frame.arbitration_id == AS_COMMAND_ID
        line = b""
        deadline = time.monotonic() + 3.0
        while b"\r" not in line and time.monotonic() < deadline:
            if select.select([can_m], [], [], 0.05)[0]:
                line += os.read(can_m, 4096)
        assert line.startswith(b"t050" + b"8" + frame.data.hex().upper().encode())
    finally:
        stopped = manager.stop()
    assert stopped  # every thread joined within sensors.stop_timeout_s (1 s)
    assert not any(r.is_alive() for r in manager.receivers.values())
    health = manager.health(clock.now_s())
    assert not any(s.alive for s in health.sources)


def test_stop_is_prompt_even_while_ports_are_missing(tmp_path) -> None:
    config = AppConfig()
    s = config.sensors
    s.gps.port = str(tmp_path / "gone-gps")
    s.imu.port = str(tmp_path / "gone-imu")
    s.can.interface, s.can.channel = "slcan", str(tmp_path / "gone-can")
    s.lidar.host = s.camera.host = "127.0.0.1"
    s.lidar.port = s.camera.port = 0
    s.reconnect_min_s, s.reconnect_max_s = 0.05, 5.0
    manager = SensorManager(config.sensors, config.car, RealClock(),
                            parsers={"camera": PlainCameraParser()})
    with manager:
        assert wait_for(lambda: all(manager.receivers[x].intake.errors >= 2
                                    for x in ("gps", "imu", "can")))
        health = {h.source: h for h in manager.health(0.0).sources}
        assert not health["gps"].alive and health["gps"].errors >= 2
        t0 = time.monotonic()
    assert time.monotonic() - t0 < 1.0 + 0.2
    assert not any(r.is_alive() for r in manager.receivers.values())
