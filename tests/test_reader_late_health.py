"""A late receiver thread is not a silent sensor (issue 19): the Sensor Manager's health calls a
live source stale only once its reader has seen the silence, or after a grace for a stuck one."""

from __future__ import annotations

import os
import threading
import time
import tty

from common.clock import RealClock, SimClock
from common.messages import ImuSample, RawBytes
from orchestrator.config import AppConfig
from sensors.imu_protocol import encode_imu_packet
from sensors.manager import SensorManager
from sensors.receiver import Intake, RawUnit, Receiver


def _imu_only(port: str = "/dev/null") -> AppConfig:
    config = AppConfig()
    sc = config.sensors
    for source in ("gps", "can", "lidar", "camera"):
        getattr(sc, source).enabled = False
    sc.imu.port = port
    return config


def _stale(manager: SensorManager, now_s: float) -> bool:
    return manager.health(now_s).stale_sources() == ("imu",)


def test_imu_is_stale_only_once_its_reader_saw_the_silence_or_the_grace_ran_out() -> None:
    config = _imu_only()
    timeout_s = config.sensors.imu.timeout_s
    grace_s = config.sensors.reader_late_grace_s
    clock = SimClock()
    manager = SensorManager(config.sensors, config.car, clock)
    # a receiver that is never started: the test plays its thread by setting when it was awake
    receiver = manager._build_receiver("imu")
    manager.receivers["imu"] = receiver
    packet = encode_imu_packet(ImuSample(1.0, 0.0, 0.0, 9.81, 0.0, 0.0, 0.1))
    assert manager.intakes["imu"].ingest(RawBytes(1.0, "imu", packet))
    receiver.awake_s = 1.0  # the thread came back from that read at 1.0 s

    late_s = 1.0 + timeout_s + 0.05
    # the thread has not come back since: its process is busy, the sensor may be fine
    assert not _stale(manager, late_s)
    # it came back and saw nothing for longer than the timeout: the sensor is silent
    receiver.awake_s = 1.0 + timeout_s + 0.01
    assert _stale(manager, late_s)
    # it saw a silence shorter than the timeout: still fine
    receiver.awake_s = 1.0 + 0.5 * timeout_s
    assert not _stale(manager, late_s)
    # a thread that does not come back for the timeout plus the grace is stuck: stale
    assert not _stale(manager, 1.0 + timeout_s + grace_s - 0.01)
    assert _stale(manager, 1.0 + timeout_s + grace_s + 0.01)


def test_offline_health_keeps_the_plain_timeout() -> None:
    # Simulation and replay parse in the caller's thread: no reader can be late.
    config = _imu_only()
    manager = SensorManager(config.sensors, config.car, SimClock())
    packet = encode_imu_packet(ImuSample(1.0, 0.0, 0.0, 9.81, 0.0, 0.0, 0.1))
    manager.ingest([RawBytes(1.0, "imu", packet)])
    timeout_s = config.sensors.imu.timeout_s
    assert not _stale(manager, 1.0 + 0.9 * timeout_s)
    assert _stale(manager, 1.0 + 1.1 * timeout_s)


def test_a_real_reader_on_a_silent_port_reports_the_imu_stale_within_its_read_timeout() -> None:
    master, slave = os.openpty()
    tty.setraw(slave)
    config = _imu_only(os.ttyname(slave))
    timeout_s = config.sensors.imu.timeout_s
    manager = SensorManager(config.sensors, config.car, RealClock())
    manager.start()
    try:
        receiver = manager.receivers["imu"]
        assert receiver.wait_connected(5.0)
        sent_s = manager.clock.now_s()
        os.write(master, encode_imu_packet(ImuSample(0.0, 0.0, 0.0, 9.81, 0.0, 0.0, 0.1)))
        deadline = time.monotonic() + 10.0
        while manager.intakes["imu"].count == 0 and time.monotonic() < deadline:
            time.sleep(0.005)
        assert manager.intakes["imu"].count == 1
        # the sensor falls silent; the reader keeps coming back empty and sees it
        while not _stale(manager, manager.clock.now_s()) and time.monotonic() < deadline:
            time.sleep(0.005)
        now_s = manager.clock.now_s()
        assert _stale(manager, now_s)
        # noticed once the silence the reader saw passed the timeout: the reader comes back at
        # least every read_timeout_s when it gets the CPU (on a busy machine it may be later,
        # but never before the timeout)
        assert now_s - sent_s > timeout_s
    finally:
        manager.stop()
        os.close(master)
        os.close(slave)


class _LateBackReceiver(Receiver):
    """A transport whose reads wait ``wait_s`` for nothing, then come back ``late_s`` after
    their wait ended (the thread waited that long for the GIL in a busy process), while the
    sensor's next unit arrived in between: the next read returns it."""

    def __init__(self, clock: SimClock, intake: Intake, packet: bytes) -> None:
        super().__init__("imu", clock, intake, read_timeout_s=0.02)
        self.sim_clock = clock
        self.packet = packet
        self.reads = 0
        self.returned = threading.Event()

    def _open(self) -> None:
        pass

    def _close(self) -> None:
        pass

    def _read(self, timeout_s: float) -> list[RawUnit]:
        self.reads += 1
        if self.reads == 1:  # the sensor's unit, at once
            return [RawBytes(self.sim_clock.now_s(), "imu", self.packet)]
        if self.reads == 2:  # a wait of 20 ms for nothing, back 0.3 s later
            self.sim_clock.set(self.sim_clock.now_s() + timeout_s + 0.3)
            return []
        self.returned.set()
        self._stop.wait(1.0)
        return []


def test_an_empty_read_back_late_proves_silence_only_up_to_when_it_began() -> None:
    config = _imu_only()
    timeout_s = config.sensors.imu.timeout_s
    clock = SimClock(1.0)
    manager = SensorManager(config.sensors, config.car, clock)
    packet = encode_imu_packet(ImuSample(1.0, 0.0, 0.0, 9.81, 0.0, 0.0, 0.1))
    receiver = _LateBackReceiver(clock, manager.intakes["imu"], packet)
    manager.receivers["imu"] = receiver
    receiver.start()
    try:
        assert receiver.returned.wait(5.0)
        now_s = clock.now_s()
        assert now_s - 1.0 > timeout_s  # the last unit is older than the timeout ...
        assert receiver.awake_s == 1.0  # ... but the reader proved silence only up to 1.0 s
        assert not _stale(manager, now_s)  # its own lateness is not the sensor's silence
    finally:
        receiver.stop()
