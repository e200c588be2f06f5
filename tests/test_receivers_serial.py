"""Serial receivers over a real pseudo-terminal pair: framing, parsing, faults, reconnection."""

from __future__ import annotations

import collections
import os
import time
import tty
from collections.abc import Callable
from pathlib import Path

import pytest

from common.clock import RealClock
from common.messages import GpsFix, RawBytes
from sensors.nmea_framing import with_checksum
from sensors.serial_receiver import LineFramer, SerialReceiver, gps_receiver

FAST = dict(read_timeout_s=0.02, reconnect_min_s=0.02, reconnect_max_s=0.1)


def make_pty() -> tuple[int, int, str]:
    """A raw pseudo-terminal pair: (master fd, slave fd, slave path)."""
    master, slave = os.openpty()
    tty.setraw(slave)
    return master, slave, os.ttyname(slave)


def wait_for(condition: Callable[[], bool], timeout_s: float = 5.0,
             action: Callable[[], object] | None = None) -> bool:
    """Poll ``condition`` (doing ``action`` before each poll) until true or timeout."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if action is not None:
            action()
        if condition():
            return True
        time.sleep(0.02)
    return condition()


def gga(k: int) -> bytes:
    return with_checksum(
        f"GPGGA,1200{k % 60:02d}.00,4919.6140,N,00833.9240,E,1,08,0.9,100.0,M,47.0,M,,")


class LineParser:
    """A trivial parser: one reading (the line) per LF-terminated line; raises on b'boom'."""

    source = "line"

    def __init__(self) -> None:
        self.rejects: collections.Counter[str] = collections.Counter()
        self._buffer = b""

    def feed(self, timestamp_s: float, data: bytes) -> list[RawBytes]:
        self._buffer += data
        *lines, self._buffer = self._buffer.split(b"\n")
        if b"boom" in lines:
            raise RuntimeError("parser bug")
        out = []
        for line in lines:
            if not line:
                self.rejects["empty"] += 1
                continue
            out.append(RawBytes(timestamp_s, "line", line))
        return out


def test_line_framer_cuts_lines_and_bounds_junk() -> None:
    framer = LineFramer(max_line=16)
    assert framer(b"$A*00\r\n$B") == [b"$A*00\r\n"]
    assert framer(b"*01\r\n") == [b"$B*01\r\n"]
    assert framer(b"\x00" * 40) == [b"\x00" * 16, b"\x00" * 16]
    assert framer(b"\n") == [b"\x00" * 8 + b"\n"]


def test_base_receiver_parses_counts_and_survives_a_parser_bug() -> None:
    master, slave, path = make_pty()
    clock = RealClock()
    receiver = SerialReceiver(clock, LineParser(), path, 115200, **FAST)
    try:
        with receiver:
            assert receiver.wait_connected(5.0)
            assert receiver.is_alive()
            assert receiver.intake.parser.rejects == collections.Counter()
            os.write(master, b"one\ntw")
            os.write(master, b"o\n\n")
            assert wait_for(lambda: receiver.intake.count >= 2)
            os.write(master, b"boom\n")
            assert wait_for(lambda: receiver.intake.errors >= 1)
            os.write(master, b"three\n")
            assert wait_for(lambda: receiver.intake.count >= 3)
            raw, readings = receiver.intake.take()
            payloads = [r.payload for r in readings]
            assert b"one" in payloads and b"two" in payloads and b"three" in payloads
            assert all(isinstance(r, RawBytes) for r in raw)
            assert receiver.intake.take() == ([], [])
            stats = receiver.stats(clock.now_s())
            assert stats.errors >= 1
            assert stats.rejects["parser_exception"] >= 1
            assert stats.age_s < 5.0 and stats.running and stats.connected
            assert receiver.intake.latest["rawbytes"].payload in (b"three", b"two", b"one")
            assert receiver.is_alive()
        assert not receiver.is_alive()
    finally:
        os.close(master)
        os.close(slave)


def test_gps_over_pty_one_sentence_per_raw_unit_with_junk_counted() -> None:
    master, slave, path = make_pty()
    clock = RealClock()
    receiver = gps_receiver(clock, path, 115200, **FAST)
    try:
        with receiver:
            assert receiver.wait_connected(5.0)
            stream = gga(1) + b"\x00\xff\xfe binary junk \x01\x02" + gga(2)
            stream += b"$GPGGA,120003.00,4919.6140,N,00833.9240,E,1,08,0.9,100.0,M,47.0,M,,*00\r\n"
            stream += gga(4)
            for i in range(0, len(stream), 7):  # arbitrary chunks
                os.write(master, stream[i:i + 7])
            assert wait_for(lambda: receiver.intake.count >= 3)
            raw, fixes = receiver.intake.take()
            assert [f.utc_time_s for f in fixes] == [43201.0, 43202.0, 43204.0]
            assert all(isinstance(f, GpsFix) for f in fixes)
            assert fixes[0].lat_deg == pytest.approx(49.3269, abs=1e-6)
            assert raw[0].payload == gga(1)
            assert all(r.source == "gps" for r in raw)
            times = [f.timestamp_s for f in fixes]
            assert times == sorted(times) and times[-1] <= clock.now_s()
            rejects = receiver.stats(clock.now_s()).rejects
            assert rejects.get("bad_checksum", 0) == 1
            assert sum(rejects.values()) >= 2  # the junk too
    finally:
        os.close(master)
        os.close(slave)


def test_vanished_port_is_reopened_when_it_comes_back(tmp_path: Path) -> None:
    link = tmp_path / "ttyGPS"
    master, slave, path = make_pty()
    os.symlink(path, link)
    clock = RealClock()
    receiver = gps_receiver(clock, str(link), 115200, **FAST)
    with receiver:
        assert receiver.wait_connected(5.0)
        k = iter(range(10_000))
        assert wait_for(lambda: receiver.intake.count >= 1,
                        action=lambda: os.write(master, gga(next(k))))
        # unplug: the device node goes away
        os.unlink(link)
        os.close(master)
        os.close(slave)
        assert wait_for(lambda: not receiver.connected.is_set())
        errors_when_gone = receiver.stats(clock.now_s()).errors
        assert errors_when_gone >= 1
        time.sleep(0.15)  # a few failed reopen attempts, with backoff
        assert receiver.is_alive()
        # plug back in: a new pty behind the same path
        master2, slave2, path2 = make_pty()
        os.symlink(path2, link)
        try:
            assert receiver.wait_connected(5.0)
            before = receiver.intake.count
            assert wait_for(lambda: receiver.intake.count > before,
                            action=lambda: os.write(master2, gga(next(k))))
            assert receiver.reconnects >= 1
            assert receiver.stats(clock.now_s()).errors > errors_when_gone
        finally:
            receiver.stop()
            os.close(master2)
            os.close(slave2)
    assert not receiver.is_alive()


def test_missing_port_at_start_is_retried_and_stop_is_prompt(tmp_path: Path) -> None:
    receiver = gps_receiver(RealClock(), str(tmp_path / "no-such-tty"), **FAST)
    receiver.start()
    assert wait_for(lambda: receiver.stats(0.0).errors >= 2)
    assert receiver.is_alive() and not receiver.connected.is_set()
    t0 = time.monotonic()
    assert receiver.stop(1.0)
    assert time.monotonic() - t0 < 1.0


def test_imu_over_pty_packets_in_any_chunking_with_corruption_counted() -> None:
    from common.messages import ImuSample
    from sensors.imu_protocol import encode_imu_packet
    from sensors.serial_receiver import imu_receiver

    master, slave, path = make_pty()
    clock = RealClock()
    receiver = imu_receiver(clock, path, 921600, **FAST)
    samples = [ImuSample(0.005 * (k + 1), 0.1 * k, -0.2, 9.81, 0.01, -0.02, 0.3)
               for k in range(40)]
    packets = [encode_imu_packet(s) for s in samples]
    corrupt = bytearray(packets[10])
    corrupt[8] ^= 0xFF  # bad CRC
    packets[10] = bytes(corrupt)
    stream = b"".join(packets[:20]) + b"\x00junk\x00" + b"".join(packets[20:])
    try:
        with receiver:
            assert receiver.wait_connected(5.0)
            for i in range(0, len(stream), 33):
                os.write(master, stream[i:i + 33])
            assert wait_for(lambda: receiver.intake.count >= 39)
            _, readings = receiver.intake.take()
            assert len(readings) == 39
            assert all(isinstance(r, ImuSample) for r in readings)
            assert readings[0].accel_z_mps2 == pytest.approx(9.81, abs=1e-5)
            assert readings[0].gyro_z_radps == pytest.approx(0.3, abs=1e-6)
            rejects = receiver.stats(clock.now_s()).rejects
            assert sum(rejects.values()) >= 2  # the bad CRC and the junk
            assert receiver.is_alive()
    finally:
        os.close(master)
        os.close(slave)
