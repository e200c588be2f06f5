"""Simulated NMEA: decodes (pynmea2 and our parser) back to the truth; noise, faults; fuzzing."""

from __future__ import annotations

import math

import numpy as np
import pynmea2
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from common.conventions import LocalTangentFrame, WorldFrame, wrap_angle
from common.messages import GroundTruth
from orchestrator.config import AppConfig
from sensors.nmea import NmeaParser
from sensors.nmea_framing import split_sentences
from simulator.gps_model import GpsModel

# Quantisation: 1e-7 arc minute ~ 0.2 mm; speed 0.001 km/h; course 0.01 deg.
POS_TOL_M = 1e-3
SPEED_TOL_MPS = 1e-3
COURSE_TOL_RAD = math.radians(0.006)


def _config(heading_rad: float = 0.7) -> AppConfig:
    config = AppConfig()
    config.sim.start_heading_enu_rad = heading_rad
    return config


def _frame(config: AppConfig) -> WorldFrame:
    sim = config.sim
    return WorldFrame(LocalTangentFrame(sim.origin_lat_deg, sim.origin_lon_deg, sim.origin_alt_m),
                      start_yaw_enu_rad=sim.start_heading_enu_rad)


def _truths(n: int, dt: float = 0.1) -> list[GroundTruth]:
    """A car driving a circle of 20 m radius at 8 m/s with a little side slip."""
    out = []
    for k in range(n):
        t = k * dt
        yaw = wrap_angle(0.4 * t)
        out.append(GroundTruth(t, 20.0 * math.sin(0.4 * t), 20.0 * (1 - math.cos(0.4 * t)),
                               yaw, 8.0, 0.3, 0.4))
    return out


def test_sentences_decode_to_truth_without_noise() -> None:
    config = _config()
    model = GpsModel(config, np.random.default_rng(3))
    model.noise = False
    frame = _frame(config)
    parser = NmeaParser()
    fixes = []
    truths = _truths(30)
    for truth in truths:
        raws = model.poll(truth.timestamp_s, truth)
        assert [r.payload[3:6] for r in raws] == [b"GGA", b"RMC", b"VTG", b"GSA"]
        for raw in raws:
            assert raw.source == "gps" and raw.payload.endswith(b"\r\n")
            assert raw.timestamp_s == pytest.approx(truth.timestamp_s)
            pynmea2.parse(raw.payload.decode("ascii").strip(), check=True)
            fixes += parser.feed(raw.timestamp_s, raw.payload)
    fixes += parser.flush()
    assert len(fixes) == len(truths)
    assert not parser.rejects
    for fix, truth in zip(fixes, truths, strict=True):
        assert fix.timestamp_s == pytest.approx(truth.timestamp_s)
        xy = frame.geodetic_to_world(fix.lat_deg, fix.lon_deg)
        assert math.hypot(xy[0] - truth.x_m, xy[1] - truth.y_m) < POS_TOL_M
        assert fix.altitude_m == pytest.approx(config.sim.origin_alt_m, abs=0.01)
        assert fix.utc_time_s == pytest.approx(model.utc_time_of_day_s(truth.timestamp_s))
        assert fix.fix_quality == 1 and fix.satellites == config.sim.gps.satellites
        if fix is fixes[0]:
            continue  # first epoch: emitted at its GGA before the parser learnt the cycle
        speed = math.hypot(truth.vx_mps, truth.vy_mps)
        assert fix.speed_mps == pytest.approx(speed, abs=SPEED_TOL_MPS)
        course_world = truth.yaw_rad + math.atan2(truth.vy_mps, truth.vx_mps)
        course_enu = frame.world_yaw_to_enu_yaw(course_world)
        assert abs(wrap_angle(fix.course_rad - course_enu)) < COURSE_TOL_RAD


def test_pynmea2_reads_model_values() -> None:
    config = _config(heading_rad=0.0)
    model = GpsModel(config, np.random.default_rng(0))
    model.noise = False
    truth = GroundTruth(0.0, 100.0, 50.0, 0.0, 5.0, 0.0, 0.0)
    lat, lon = _frame(config).world_to_geodetic(np.array([100.0, 50.0]))
    sentences = [pynmea2.parse(r.payload.decode().strip()) for r in model.poll(0.0, truth)]
    gga, rmc, vtg, gsa = sentences
    assert gga.latitude == pytest.approx(float(lat), abs=1e-8)
    assert gga.longitude == pytest.approx(float(lon), abs=1e-8)
    assert rmc.status == "A"
    assert float(rmc.spd_over_grnd) * 1852 / 3600 == pytest.approx(5.0, abs=1e-3)
    assert float(vtg.spd_over_grnd_kmph) == pytest.approx(18.0, abs=1e-3)
    # Driving along world x = east with start heading 0: course 90 deg from north.
    assert float(vtg.true_track) == pytest.approx(90.0, abs=0.01)
    assert gsa.mode_fix_type == "3"


def test_noise_statistics_match_config() -> None:
    """Position error about the configured white sigma and a slowly wandering bias."""
    config = _config()
    model = GpsModel(config, np.random.default_rng(11))
    frame = _frame(config)
    parser = NmeaParser()
    errors = []
    for k in range(3000):
        t = k * 0.1
        for raw in model.poll(t, GroundTruth(t, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)):
            for fix in parser.feed(raw.timestamp_s, raw.payload):
                errors.append(frame.geodetic_to_world(fix.lat_deg, fix.lon_deg))
    err = np.array(errors)
    assert len(err) >= 2990
    gps = config.sim.gps
    total_sigma = math.hypot(gps.sigma_m, gps.bias_sigma_m)
    per_axis_std = err.std(axis=0)
    assert np.all(per_axis_std > 0.7 * gps.sigma_m)
    assert np.all(per_axis_std < 1.4 * total_sigma)
    # Successive differences see only the white part (the bias barely moves in 0.1 s).
    diff_std = np.diff(err, axis=0).std(axis=0) / math.sqrt(2.0)
    assert np.allclose(diff_std, gps.sigma_m, rtol=0.1)


def test_same_seed_same_bytes() -> None:
    runs = []
    for _ in range(2):
        model = GpsModel(_config(), np.random.default_rng(42))
        runs.append([r.payload for t in _truths(20) for r in model.poll(t.timestamp_s, t)])
    assert runs[0] == runs[1]


def test_dropout_and_corruption() -> None:
    config = _config()
    model = GpsModel(config, np.random.default_rng(5))
    truths = _truths(20)
    model.dropout = True
    assert all(model.poll(t.timestamp_s, t) == [] for t in truths[:10])
    model.dropout = False
    assert len(model.poll(truths[10].timestamp_s, truths[10])) == 4

    model = GpsModel(config, np.random.default_rng(6))
    model.corrupt_fraction = 1.0
    parser = NmeaParser()
    fixes = []
    for t in truths:
        for raw in model.poll(t.timestamp_s, t):
            fixes += parser.feed(raw.timestamp_s, raw.payload)
    fixes += parser.flush()
    assert fixes == []
    assert parser.rejects["bad_checksum"] == 4 * len(truths)


def test_model_sentences_survive_arbitrary_chunking_and_junk() -> None:
    model = GpsModel(_config(), np.random.default_rng(8))
    stream = b"".join(r.payload for t in _truths(10) for r in model.poll(t.timestamp_s, t))
    rng = np.random.default_rng(1)
    ubx = bytes([0xB5, 0x62, 0x01, 0x07, 0x5C, 0x00]) + bytes(rng.integers(0, 256, 92).tolist())
    noisy = ubx + stream[:150] + ubx + stream[150:]
    parser = NmeaParser()
    fixes = []
    pos = 0
    while pos < len(noisy):
        n = int(rng.integers(1, 40))
        fixes += parser.feed(0.0, noisy[pos:pos + n])
        pos += n
    fixes += parser.flush()
    # The UBX block may swallow at most the sentence it interrupts.
    assert len(fixes) >= 9
    assert parser.rejects["bad_checksum"] == 0


def test_split_sentences_handles_missing_line_ends() -> None:
    data = b"$GPGSA,A,1,,,,,,,,,,,,,,,*1E$GPRMC,235949.00,V,,,,,,,161206,,,N*44\r\nxx$GP"
    assert split_sentences(data) == [b"$GPGSA,A,1,,,,,,,,,,,,,,,*1E",
                                     b"$GPRMC,235949.00,V,,,,,,,161206,,,N*44", b"$GP"]


@settings(max_examples=300, deadline=None)
@given(st.lists(st.binary(max_size=120), max_size=8))
def test_fuzz_random_bytes_never_raise(chunks: list[bytes]) -> None:
    parser = NmeaParser()
    for chunk in chunks:
        for fix in parser.feed(0.0, chunk):
            assert math.isfinite(fix.lat_deg) and math.isfinite(fix.lon_deg)
    parser.flush()


_FIELD = st.text(alphabet="0123456789.,-NSEWAVM*$ABCDEF", max_size=12)


@settings(max_examples=300, deadline=None)
@given(st.sampled_from(["GPGGA", "GNRMC", "GPGLL", "GPVTG", "GNGNS", "GPGSA", "GPZDA"]),
       st.lists(_FIELD, max_size=16), st.booleans())
def test_fuzz_nmea_like_sentences_never_raise(kind: str, fields: list[str], good: bool) -> None:
    """Plausible sentences with valid checksums and garbage fields: no exception, sane fixes."""
    from sensors.nmea_framing import with_checksum

    body = ",".join([kind, *fields]).replace("*", "").replace("$", "")
    sentence = with_checksum(body) if good else ("$" + body + "\r\n").encode()
    parser = NmeaParser()
    fixes = parser.feed(0.0, sentence) + parser.flush()
    for fix in fixes:
        assert -90.0 <= fix.lat_deg <= 90.0 and -180.0 <= fix.lon_deg <= 180.0
