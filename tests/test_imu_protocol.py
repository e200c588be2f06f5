"""VectorNav binary protocol: encoding per the documented rules, parsing, resync, rejects."""

from __future__ import annotations

import math
import struct

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from common.messages import ImuSample
from sensors.imu_protocol import (
    PACKET_BYTES,
    ImuParser,
    crc16,
    encode_imu_packet,
)

SAMPLE = ImuSample(2.5, 0.5, -1.25, 9.81, 0.01, -0.02, 0.3)


def _f32(x: float) -> float:
    return struct.unpack("<f", struct.pack("<f", x))[0]


def _crc_reference(data: bytes) -> int:
    """VectorNav's CRC routine from the user manual, transcribed literally."""
    crc = 0
    for byte in data:
        crc = ((crc >> 8) | (crc << 8)) & 0xFFFF
        crc ^= byte
        crc ^= (crc & 0xFF) >> 4
        crc ^= (crc << 12) & 0xFFFF
        crc ^= ((crc & 0x00FF) << 5) & 0xFFFF
    return crc


def test_crc_matches_manual_routine() -> None:
    rng = np.random.default_rng(0)
    for n in (0, 1, 5, 37, 100):
        data = bytes(rng.integers(0, 256, n).tolist())
        assert crc16(data) == _crc_reference(data)
    assert crc16(b"123456789") == 0x31C3  # CRC-16/XMODEM check value


def test_packet_layout_follows_the_documented_format() -> None:
    packet = encode_imu_packet(SAMPLE, sensor_time_s=12.5)
    assert len(packet) == PACKET_BYTES == 38
    assert packet[0] == 0xFA and packet[1] == 0x01
    assert struct.unpack_from("<H", packet, 2)[0] == 0x0121
    assert struct.unpack_from("<Q", packet, 4)[0] == 12_500_000_000
    gyro = struct.unpack_from("<3f", packet, 12)
    accel = struct.unpack_from("<3f", packet, 24)
    # Sensor frame: x forward, y right, z down.
    assert gyro == pytest.approx((0.01, 0.02, -0.3), abs=1e-7)
    assert accel == pytest.approx((0.5, 1.25, -9.81), abs=1e-6)
    assert struct.unpack(">H", packet[-2:])[0] == _crc_reference(packet[1:-2])
    assert _crc_reference(packet[1:]) == 0


def test_round_trip_within_float32() -> None:
    parser = ImuParser()
    (got,) = parser.feed(SAMPLE.timestamp_s, encode_imu_packet(SAMPLE))
    assert got.timestamp_s == pytest.approx(SAMPLE.timestamp_s, abs=1e-9)
    for name in ("accel_x_mps2", "accel_y_mps2", "accel_z_mps2", "gyro_x_radps",
                 "gyro_y_radps", "gyro_z_radps"):
        assert getattr(got, name) == _f32(getattr(SAMPLE, name)), name
    assert not parser.rejects


def test_arbitrary_chunks_junk_and_bad_crc_resync() -> None:
    samples = [ImuSample(k * 0.005, 0.1 * k, 0.0, 9.81, 0.0, 0.0, 0.01 * k) for k in range(20)]
    packets = [encode_imu_packet(s) for s in samples]
    bad = bytearray(packets[5])
    bad[20] ^= 0x10
    packets[5] = bytes(bad)
    stream = b"\x00\xfa\x13junk" + b"".join(packets[:10]) + b"\xfa\x01" + b"".join(packets[10:])
    parser = ImuParser()
    got = []
    rng = np.random.default_rng(3)
    pos = 0
    while pos < len(stream):
        n = int(rng.integers(1, 50))
        got += parser.feed(1.0, stream[pos:pos + n])
        pos += n
    got += parser.flush()
    assert [round(s.accel_x_mps2, 4) for s in got] == [
        round(0.1 * k, 4) for k in range(20) if k != 5]
    assert parser.rejects["bad_crc"] >= 1
    assert parser.rejects["truncated"] == 1  # the "FA 01" fragment before packet 10


def test_truncated_packet_followed_by_next_packet() -> None:
    a = encode_imu_packet(ImuSample(0.0, 1.0, 0, 9.81, 0, 0, 0))
    b = encode_imu_packet(ImuSample(0.005, 2.0, 0, 9.81, 0, 0, 0))
    parser = ImuParser()
    got = parser.feed(0.01, a[:20] + b)
    assert [s.accel_x_mps2 for s in got] == [2.0]
    assert parser.rejects["truncated"] == 1
    parser.feed(0.02, a[:30])
    parser.flush()
    assert parser.rejects["truncated"] == 2


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_non_finite_values_rejected(bad: float) -> None:
    parser = ImuParser()
    packet = encode_imu_packet(ImuSample(1.0, 0.0, bad, 9.81, 0.0, 0.0, 0.0))
    good = encode_imu_packet(ImuSample(1.005, 0.0, 0.0, 9.81, 0.0, 0.0, 0.0))
    got = parser.feed(1.01, packet + good)
    assert len(got) == 1 and math.isfinite(got[0].accel_y_mps2)
    assert parser.rejects["nan"] == 1


def test_unsupported_groups_counted() -> None:
    body = bytes([0x04]) + struct.pack("<H", 0x0001) + bytes(12)
    packet = b"\xfa" + body + struct.pack(">H", crc16(body))
    parser = ImuParser()
    got = parser.feed(0.0, packet + encode_imu_packet(SAMPLE))
    assert len(got) == 1
    assert parser.rejects["unsupported"] >= 1


def test_batched_packets_get_sensor_spaced_timestamps() -> None:
    """Several packets read in one chunk are stamped by the sensor clock, not all alike."""
    parser = ImuParser()
    stream = b"".join(encode_imu_packet(ImuSample(0, 0, 0, 9.81, 0, 0, 0), 100.0 + k * 0.005)
                      for k in range(10))
    first = parser.feed(3.0, stream[:38])
    rest = parser.feed(3.06, stream[38:])
    stamps = [s.timestamp_s for s in first + rest]
    # Exact spacing up to the 100 ppm drift allowance of the offset.
    assert stamps == pytest.approx([3.0 + k * 0.005 for k in range(10)], abs=1e-5)
    assert all(s <= 3.06 + 1e-12 for s in stamps)


@settings(max_examples=300, deadline=None)
@given(st.lists(st.binary(max_size=100), max_size=8))
def test_fuzz_random_bytes_never_raise(chunks: list[bytes]) -> None:
    parser = ImuParser()
    for chunk in chunks:
        for sample in parser.feed(0.0, chunk):
            assert math.isfinite(sample.accel_x_mps2)
    parser.flush()


@settings(max_examples=200, deadline=None)
@given(st.binary(min_size=1, max_size=60), st.integers(min_value=0, max_value=37))
def test_fuzz_packets_with_inserted_garbage(garbage: bytes, where: int) -> None:
    packet = encode_imu_packet(SAMPLE)
    parser = ImuParser()
    got = parser.feed(0.0, packet[:where] + garbage + packet[where:] + packet)
    got += parser.flush()
    # Whatever the garbage did, the clean packet after it still decodes.
    assert any(s.accel_z_mps2 == _f32(9.81) for s in got)


def test_mixed_infinities_rejected_without_losing_the_stream() -> None:
    parser = ImuParser()
    bad = encode_imu_packet(ImuSample(0.0, math.inf, -math.inf, 9.81, 0.0, 0.0, 0.0))
    got = parser.feed(0.0, bad + encode_imu_packet(SAMPLE))
    assert len(got) == 1 and parser.rejects == {"nan": 1}
