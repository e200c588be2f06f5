"""Hostile bytes into every sensor parser (issue 19.4): property-based, a few hundred each.

Each parser takes arbitrary bytes, and bytes that are almost right (a real sentence with a
correct checksum around garbage fields, a packet with a valid CRC around any payload, a
well-formed VLP-16 packet with any content...), and must never raise: what it cannot use is a
counted rejection, and what it passes on is sane (finite numbers, in range). Hypothesis runs
derandomized (a fixed seed) and without a deadline (CI machines are loaded).
"""

from __future__ import annotations

import math
import struct
import tempfile
from pathlib import Path

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from common.errors import DecodeError
from common.messages import CanFrame, ImuSample
from sensors.camera_codec import CameraParser, decode_camera_cones
from sensors.can_codec import AS_COMMAND_ID, CanCodec
from sensors.decode_can import decode_log
from sensors.decode_lidar import read_pcap_udp
from sensors.imu_protocol import ImuParser, crc16, encode_imu_packet
from sensors.lidar_parser import LidarParser
from sensors.nmea import NmeaParser
from sensors.nmea_framing import with_checksum

HOSTILE = settings(max_examples=300, deadline=None, derandomize=True, database=None,
                   suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])

# Real sentences of the kinds the parser reads (from the gpsd captures' receivers).
SENTENCES = [
    "GPGGA,143306.00,5546.83315,N,02334.72613,E,1,08,1.28,129.9,M,26.9,M,,",
    "GNRMC,120213.000,A,5957.0062,N,01100.6429,E,0.00,0.00,310722,,,D,V",
    "GNGNS,120213.000,5957.0062,N,01100.6429,E,NDD,11,1.3,168.9,39.5,,,V",
    "GPGLL,5547.82107,N,02334.14132,E,152504.50,A,A",
    "GPVTG,16.99,T,,M,0.687,N,1.272,K,A",
    "GNGSA,A,3,68,69,70,78,84,85,,,,,,,1.5,1.3,1.0,2",
    "GPGSV,2,1,08,01,10,158,44,03,72,164,42,11,24,279,,14,30,119,48",
    "GPZDA,152504.50,09,12,2009,00,00",
    "GPHDT,274.07,T",
    "PASHR,085335.000,224.19,T,-01.26,+00.83,+00.00,0.101,0.113,0.267,1,0",
]
FIELD = st.text(alphabet=st.characters(min_codepoint=0x20, max_codepoint=0x7E,
                                       exclude_characters="$!*,"), max_size=14)


def _fix_is_sane(fix: object) -> None:
    lat, lon, utc = fix.lat_deg, fix.lon_deg, fix.utc_time_s  # type: ignore[attr-defined]
    assert math.isfinite(lat) and -90.0 <= lat <= 90.0
    assert math.isfinite(lon) and -180.0 <= lon <= 180.0
    assert math.isnan(utc) or 0.0 <= utc < 86401.0
    assert fix.fix_quality >= 1  # type: ignore[attr-defined]


# -- NMEA -------------------------------------------------------------------------------------


@HOSTILE
@given(st.binary(max_size=600), st.integers(0, 600))
def test_nmea_any_bytes_never_raise_and_chunking_does_not_matter(data: bytes, cut: int) -> None:
    whole = NmeaParser()
    fixes = whole.feed(0.0, data) + whole.flush()
    split = NmeaParser()
    parts = split.feed(0.0, data[:cut]) + split.feed(0.0, data[cut:]) + split.flush()
    assert [(f.lat_deg, f.lon_deg, f.utc_time_s) for f in fixes] == [
        (f.lat_deg, f.lon_deg, f.utc_time_s) for f in parts]
    for fix in fixes:
        _fix_is_sane(fix)
    assert whole.rejects["parser_error"] == 0


@HOSTILE
@given(st.lists(st.tuples(st.sampled_from(SENTENCES),
                          st.dictionaries(st.integers(0, 20), FIELD, max_size=4),
                          st.integers(0, 25)), min_size=1, max_size=12))
def test_nmea_checksummed_sentences_with_garbage_fields(
        edits: list[tuple[str, dict[int, str], int]]) -> None:
    """The checksum is right, so every field reaches the handlers: a field's garbage, a field
    too few or too many must be a counted rejection, never an exception or a mad fix."""
    parser = NmeaParser()
    fixes = []
    for t, (sentence, replace, keep) in enumerate(edits):
        fields = sentence.split(",")
        for index, text in replace.items():
            if index < len(fields):
                fields[index] = text
        body = ",".join(fields[:max(1, keep)])
        fixes += parser.feed(0.1 * t, with_checksum(body))
    fixes += parser.flush()
    for fix in fixes:
        _fix_is_sane(fix)
    assert parser.rejects["parser_error"] == 0
    assert parser.counts["sentences"] + sum(parser.rejects.values()) >= 1


# -- IMU --------------------------------------------------------------------------------------


def _sample_is_sane(sample: ImuSample) -> None:
    for value in (sample.timestamp_s, sample.accel_x_mps2, sample.accel_y_mps2,
                  sample.accel_z_mps2, sample.gyro_x_radps, sample.gyro_y_radps,
                  sample.gyro_z_radps):
        assert math.isfinite(value)


@HOSTILE
@given(st.lists(st.binary(max_size=200), max_size=8))
def test_imu_any_bytes_never_raise(chunks: list[bytes]) -> None:
    parser = ImuParser()
    samples = []
    for k, chunk in enumerate(chunks):
        samples += parser.feed(0.005 * k, b"\xfa" + chunk if k % 2 else chunk)
    samples += parser.flush()
    for sample in samples:
        _sample_is_sane(sample)


@HOSTILE
@given(st.integers(0, 255), st.integers(0, 0xFFFF), st.binary(max_size=200),
       st.booleans())
def test_imu_valid_crc_around_any_payload(groups: int, fields: int, payload: bytes,
                                          then_good: bool) -> None:
    """A packet whose CRC is right but whose groups, field mask or length are anything."""
    body = bytes([groups]) + struct.pack("<H", fields) + payload
    packet = b"\xfa" + body + struct.pack(">H", crc16(body))
    good = encode_imu_packet(ImuSample(1.0, 0.1, 0.2, 9.8, 0.01, 0.02, 0.03))
    parser = ImuParser()
    samples = parser.feed(1.0, packet + (good if then_good else b""))
    samples += parser.flush()
    for sample in samples:
        _sample_is_sane(sample)
    if then_good:  # the parser finds the good packet after whatever came before
        assert any(s.accel_z_mps2 == np.float32(-9.8) * -1 for s in samples)


@HOSTILE
@given(st.lists(st.floats(width=32), min_size=6, max_size=6), st.floats(0.0, 1e6))
def test_imu_non_finite_values_are_counted_never_passed(values: list[float],
                                                       t_s: float) -> None:
    parser = ImuParser(use_sensor_time=False)
    packet = encode_imu_packet(ImuSample(t_s, *values))
    samples = parser.feed(t_s, packet)
    if all(math.isfinite(v) for v in values):
        assert len(samples) == 1
    else:
        assert samples == [] and parser.rejects["nan"] == 1


# -- CAN --------------------------------------------------------------------------------------

CODEC = CanCodec()
KNOWN_IDS = sorted(m.frame_id for m in CODEC.db.messages)


@HOSTILE
@given(st.one_of(st.sampled_from(KNOWN_IDS), st.integers(0, 0x7FF), st.integers(0, 0x1FFFFFFF)),
       st.binary(max_size=64), st.booleans())
def test_can_any_frame_through_the_dbc(ident: int, data: bytes, extended: bool) -> None:
    codec = CanCodec()
    frame = CanFrame(1.0, ident, data, extended)
    readings = codec.decode(frame)
    command = codec.decode_command(frame)
    decoded = codec.decode_signals(frame, decode_choices=True)
    message = codec._by_id.get(ident)
    if message is None or message.is_extended_frame != extended:  # not one of our frames
        assert readings == [] and command is None and decoded is None
        assert codec.rejects["unknown_id"] == 2 + (ident == AS_COMMAND_ID)
    elif len(data) != message.length:  # a short (or long) frame
        assert readings == [] and decoded is None
        assert codec.rejects["bad_length"] >= 2
    for reading in readings:
        for value in vars(reading).values() if hasattr(reading, "__dict__") else ():
            assert not isinstance(value, float) or not math.isnan(value)
    if command is not None:
        assert ident == AS_COMMAND_ID
        assert 0.0 <= command.throttle <= 1.0 and 0.0 <= command.brake <= 1.0
        assert math.isfinite(command.steering_rad)


@settings(HOSTILE, max_examples=100)
@given(st.binary(max_size=400), st.sampled_from([".log", ".asc", ".blf"]))
def test_can_log_of_garbage_is_counted_or_refused(data: bytes, suffix: str) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / f"garbage{suffix}"
        path.write_bytes(data)
        try:
            records = list(decode_log(path))
        except DecodeError:
            return  # "not a CAN log python-can reads": one clear line
        assert "counts" in records[-1]


# -- LiDAR ------------------------------------------------------------------------------------


def _vlp16_packet(azimuth: int, returns: bytes, stamp_us: int, factory: bytes) -> bytes:
    blocks = b"".join(b"\xff\xee" + struct.pack("<H", (azimuth + 40 * b) % 36000)
                      + returns[:96].ljust(96, b"\x00") for b in range(12))
    return blocks + struct.pack("<I", stamp_us) + factory


@HOSTILE
@given(st.lists(st.one_of(st.binary(max_size=1300),
                          st.binary(min_size=1206, max_size=1206),
                          st.binary(min_size=1206, max_size=1206).map(
                              lambda b: b"".join(b"\xff\xee" + b[i * 100 + 2:i * 100 + 100]
                                                 for i in range(12)) + b[1200:])),
                max_size=6))
def test_lidar_any_datagram_never_raises(datagrams: list[bytes]) -> None:
    parser = LidarParser()
    for k, datagram in enumerate(datagrams):
        for cones in parser.feed(0.001327 * k, datagram):
            assert all(math.isfinite(c.x_m) and math.isfinite(c.y_m) for c in cones.cones)
    parser.flush()
    assert parser.counts["packets"] + sum(parser.rejects.values()) >= len(datagrams) - 1


@settings(HOSTILE, max_examples=150)
@given(st.lists(st.tuples(st.integers(0, 35999), st.binary(min_size=96, max_size=96),
                          st.integers(0, 2**32 - 1)), min_size=1, max_size=20),
       st.sampled_from([b"\x37\x22", b"\x37\x21", b"\x39\x22", b"\x37\x28", b"\x37\x24",
                        b"\x00\x00", b"\x38\x22"]))
def test_lidar_well_formed_packets_with_any_content(
        packets: list[tuple[int, bytes, int]], factory: bytes) -> None:
    """Any azimuths, distances, timestamps and factory bytes in a well-formed packet: points
    are finite, and another model's id is refused, never decoded."""
    parser = LidarParser(all_points=True)
    decoded = []
    parser.on_packet = lambda _t, p: decoded.append(p)
    for k, (azimuth, returns, stamp) in enumerate(packets):
        parser.feed(0.001327 * (k + 1), _vlp16_packet(azimuth, returns, stamp, factory))
    parser.flush()
    if parser.last_sweep is not None:
        assert np.isfinite(parser.last_sweep.points).all()
        assert np.isfinite(parser.last_sweep.times_s).all()
    if factory[1] not in (0x21, 0x22) or factory[0] not in (0x37, 0x38, 0x39):
        assert decoded == [] and parser.rejects["wrong_model"] == len(packets)
    assert len(decoded) + parser.rejects["wrong_model"] == len(packets)


def _pcap(frames: list[bytes]) -> bytes:
    header = struct.pack("<IHHiIII", 0xA1B2C3D4, 2, 4, 0, 0, 65535, 1)
    body = b"".join(struct.pack("<IIII", 1, k, len(f), len(f)) + f for k, f in enumerate(frames))
    return header + body


@settings(HOSTILE, max_examples=200)
@given(st.lists(st.binary(max_size=120), max_size=5), st.integers(0, 400),
       st.binary(max_size=8))
def test_pcap_reader_on_mangled_files(frames: list[bytes], at: int, junk: bytes) -> None:
    udp = (b"\x00" * 12 + b"\x08\x00" + bytes([0x45, 0]) + struct.pack(">H", 28 + 10)
           + b"\x00" * 5 + b"\x11" + b"\x00" * 10 + struct.pack(">HHHH", 1, 2368, 18, 0)
           + b"0123456789")
    data = bytearray(_pcap([udp, *frames]))
    data[at:at + len(junk)] = junk
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "x.pcap"
        path.write_bytes(bytes(data))
        try:
            for _stamp, port, payload in read_pcap_udp(path):
                assert 0 <= port <= 0xFFFF and isinstance(payload, bytes)
        except DecodeError:
            pass  # not a pcap file at all: one clear error


# -- Camera -----------------------------------------------------------------------------------


@HOSTILE
@given(st.binary(max_size=300))
def test_camera_any_bytes_never_raise(data: bytes) -> None:
    parser = CameraParser()
    out = parser.feed(5.0, data)
    assert len(out) + sum(parser.rejects.values()) == 1


@HOSTILE
@given(st.floats(allow_nan=True, allow_infinity=True), st.integers(0, 2**32 - 1),
       st.lists(st.tuples(st.floats(width=32), st.floats(width=32), st.integers(-3, 9),
                          st.floats(width=32)), max_size=6))
def test_camera_any_field_values(timestamp_s: float, frame_id: int,
                                 cones: list[tuple[float, float, int, float]]) -> None:
    from sensors import camera_pb2

    msg = camera_pb2.CameraCones(timestamp_s=timestamp_s, frame_id=frame_id)
    for x, y, colour, confidence in cones:
        cone = msg.cones.add(x_m=x, y_m=y, confidence=confidence)
        cone.colour = colour  # type: ignore[assignment] (open enum: any int goes on the wire)
    payload = msg.SerializeToString()
    parser = CameraParser()
    out = parser.feed(timestamp_s if math.isfinite(timestamp_s) else 0.0, payload)
    if out:
        decoded = decode_camera_cones(payload)
        assert math.isfinite(decoded.timestamp_s) and decoded.timestamp_s >= 0.0
        for cone in out[0].cones:
            assert math.isfinite(cone.x_m) and math.isfinite(cone.y_m)
            assert 0.0 <= cone.confidence <= 1.0
    else:
        assert sum(parser.rejects.values()) == 1
