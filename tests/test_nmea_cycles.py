"""The NMEA receiver reports one fix per receiver cycle, as gpsd does (issue 44).

Against gpsd's answer keys for the 12 shared captures, per cycle: gpsd's TPV reports with mode
>= 2 grouped by their time (gpsd may report one cycle several times, with the position of
different sentences); we must report every such cycle once, with that time and one of those
positions, and nothing else. And on synthetic streams: a chartplotter's instrument bus (GP GGA,
RMC and GLL each cycle, interleaved with depth, wind, heading and log talkers) gives exactly one
fix per cycle and counts the instrument sentences; cycle enders are learned; a cycle that never
reaches its ender is counted, not reported.
"""

from __future__ import annotations

import math
import random
from pathlib import Path

import pytest

from sensors.cli import decode_nmea_file
from sensors.gpsd_agreement import Agreement, agreement
from sensors.nmea import NmeaParser
from sensors.nmea_framing import split_address, with_checksum
from support.shared_data import shared_path

DATA = shared_path("nmea")
CAPTURES = sorted(DATA.glob("*.log"))

# -- gpsd's answer keys, per cycle ----------------------------------------------------------


def compare_with_gpsd(capture: Path) -> Agreement:
    """gpsd's cycles in the capture's answer key, those we report, and our extra fixes."""
    reports = capture.with_name(capture.name + ".chk").read_text(errors="replace")
    return agreement(reports, list(decode_nmea_file(capture))[:-1])


@pytest.mark.shared_data("nmea")
@pytest.mark.parametrize("capture", CAPTURES, ids=lambda p: p.name)
def test_every_gpsd_cycle_once_and_nothing_else(capture: Path) -> None:
    result = compare_with_gpsd(capture)
    total, matched, extra = result.cycles, result.found, result.extra
    assert total > 0
    assert matched == total, f"{capture.name}: {matched}/{total} of gpsd's cycles"
    assert extra == [], f"{capture.name}: fixes gpsd did not report: {extra[:3]}"


# -- synthetic streams ----------------------------------------------------------------------

_INSTRUMENTS = ["SDDPT,12.3,0.5,", "SDDBT,40.3,f,12.3,M,6.7,F", "WIMWV,045.0,R,10.5,N,A",
                "WIMWD,328.2,T,326.8,M,11.2,N,5.8,M", "IIHDG,123.4,,,1.5,W",
                "IIVHW,231.3,T,229.9,M,6.6,N,12.3,K", "HCHDG,120.0,,,2.0,W", "SDMTW,15.0,C",
                "IIXDR,C,,C,AIRTEMP,A,-1.0,D,HEEL", "SDVLW,,N,545.6,N,1109.4,N", "HCHDT,121.5,T",
                "IIMTW,15.0,C", "PSMDST,C,1,2"]


def _hms(utc_s: float) -> str:
    hours, rest = divmod(utc_s, 3600.0)
    minutes, seconds = divmod(rest, 60.0)
    return f"{int(hours):02d}{int(minutes):02d}{seconds:05.2f}"


def _position(k: int) -> tuple[str, str, float, float]:
    lat_min, lon_min = 10.0 + 0.0012 * k, 30.0 + 0.0007 * k
    return (f"50{lat_min:07.4f}", f"001{lon_min:07.4f}", 50.0 + lat_min / 60.0,
            -(1.0 + lon_min / 60.0))


def chartplotter_stream(cycles: int, seed: int = 1, shuffle_fixes: bool = False,
                        ) -> tuple[list[str], list[tuple[float, float, float]], int]:
    """A boat's instrument bus at 1 Hz: per cycle GP GGA, RMC and GLL (same time and position)
    with 3-8 instrument sentences before, between and after each (SD depth, WI wind, II and HC
    heading, log, temperature, a proprietary one). Returns the sentence bodies, the truth per
    cycle (UTC s, lat deg, lon deg) and how many instrument sentences it holds."""
    rng = random.Random(seed)
    bodies: list[str] = []
    truth = []
    instruments = 0
    for k in range(cycles):
        utc_s = 10 * 3600 + 5 * 60 + k
        t = _hms(utc_s)
        lat, lon, lat_deg, lon_deg = _position(k)
        fixes = [f"GPGGA,{t},{lat},N,{lon},W,1,08,1.0,5.0,M,47.0,M,,",
                 f"GPRMC,{t},A,{lat},N,{lon},W,5.0,90.0,281126,,,A",
                 f"GPGLL,{lat},N,{lon},W,{t},A,A"]
        if shuffle_fixes:
            rng.shuffle(fixes)
        for sentence in fixes + [""]:
            for _ in range(rng.randint(1, 3)):
                bodies.append(rng.choice(_INSTRUMENTS))
                instruments += 1
            if sentence:
                bodies.append(sentence)
        truth.append((float(utc_s), lat_deg, lon_deg))
    return bodies, truth, instruments


def _run(bodies: list[str]) -> tuple[NmeaParser, list]:
    parser = NmeaParser()
    fixes = []
    for i, body in enumerate(bodies):
        fixes += parser.feed(0.01 * i, with_checksum(body))
    return parser, fixes + parser.flush()


@pytest.mark.parametrize("shuffle", [False, True], ids=["fixed_order", "order_varies"])
def test_chartplotter_bus_gives_one_fix_per_cycle(shuffle: bool) -> None:
    bodies, truth, instruments = chartplotter_stream(40, shuffle_fixes=shuffle)
    parser, fixes = _run(bodies)
    assert len(fixes) == len(truth)
    for fix, (utc_s, lat_deg, lon_deg) in zip(fixes, truth, strict=True):
        assert fix.utc_time_s == pytest.approx(utc_s, abs=1e-6)
        assert fix.lat_deg == pytest.approx(lat_deg, abs=1e-9)
        assert fix.lon_deg == pytest.approx(lon_deg, abs=1e-9)
        if not shuffle:  # GGA, RMC, GLL: reported at the GLL, with the GGA's height
            assert fix.altitude_m == pytest.approx(5.0) and fix.satellites == 8
    assert parser.counts["unused"] == instruments
    assert parser.counts["sentences"] == instruments + 3 * len(truth)
    assert parser.counts["DPT"] + parser.counts["MWV"] + parser.counts["HDG"] > 0
    assert parser.talkers["GP"] == 3 * len(truth)
    assert {"SD", "WI", "II", "HC"} <= set(parser.talkers)
    assert sum(parser.rejects.values()) == 0


def test_instrument_sentences_alone_give_no_fix() -> None:
    parser, fixes = _run(_INSTRUMENTS * 5)
    assert fixes == []
    assert parser.counts["unused"] == len(_INSTRUMENTS) * 5
    assert sum(parser.rejects.values()) == 0


def test_fix_reported_at_the_learned_ender() -> None:
    """A receiver's burst RMC, VTG, GGA, GSA, GSV, GLL: GLL (the last time-stamped sentence
    before the time changes) is learned as the ender after the first cycle; from then on each
    cycle's fix comes out at its GLL, with the RMC's speed and the GGA's height."""
    bodies = []
    for k in range(4):
        t = _hms(3600.0 + k)
        lat, lon, _, _ = _position(k)
        bodies += [f"GNRMC,{t},A,{lat},N,{lon},W,10.0,45.0,281126,,,A",
                   "GNVTG,45.0,T,,M,10.0,N,18.52,K,A",
                   f"GNGGA,{t},{lat},N,{lon},W,1,12,0.8,100.0,M,47.0,M,,",
                   "GNGSA,A,3,01,02,03,04,,,,,,,,,1.5,0.8,1.2",
                   "GPGSV,1,1,04,01,40,083,46,02,17,308,41,03,07,344,39,04,22,228,45",
                   f"GNGLL,{lat},N,{lon},W,{t},A,A"]
    parser = NmeaParser()
    emitted_at = []
    for body in bodies:
        for fix in parser.feed(0.0, with_checksum(body)):
            emitted_at.append((body[2:5], fix))
    emitted_at += [("flush", fix) for fix in parser.flush()]
    assert parser.cycle_enders == {"GLL"}
    assert [where for where, _ in emitted_at] == ["RMC", "GLL", "GLL", "GLL"]
    last = emitted_at[-1][1]
    assert last.speed_mps == pytest.approx(10.0 * 1852 / 3600) and last.altitude_m == 100.0


def test_cycle_that_never_reaches_its_ender_is_counted_not_reported() -> None:
    """gpsd drops a cycle cut short (a splice, a restart, a corrupted ender): so do we, and
    count it."""
    full = []
    for k in range(3):
        t = _hms(7200.0 + k)
        lat, lon, _, _ = _position(k)
        full += [f"GPRMC,{t},A,{lat},N,{lon},W,1.0,10.0,281126,,,A",
                 f"GPGGA,{t},{lat},N,{lon},W,1,07,1.1,20.0,M,47.0,M,,"]
    cut = full[:4] + [full[4]] + [full[0].replace(_hms(7200.0), _hms(7300.0)), full[1].replace(
        _hms(7200.0), _hms(7300.0))]
    parser, fixes = _run(cut)
    assert [f.utc_time_s for f in fixes] == [7200.0, 7201.0, 7300.0]
    assert parser.rejects["incomplete_cycle"] == 1


def test_stream_without_times_gives_a_fix_per_position_sentence() -> None:
    """A GLL without its time field (Garmin 65): each repeated position sentence is a cycle."""
    bodies = [f"GPGLL,{_position(k)[0]},N,{_position(k)[1]},W,,A" for k in range(5)]
    _, fixes = _run(bodies)
    assert len(fixes) == 5
    assert all(math.isnan(f.utc_time_s) for f in fixes)


def test_addresses() -> None:
    assert split_address("GPGGA") == ("GP", "GGA")
    assert split_address("SDDPT") == ("SD", "DPT")
    assert split_address("PGRME") == ("P", "PGRME")
    with pytest.raises(ValueError):
        split_address("gp gga")
    parser, fixes = _run(["GP GGA,1,2,3"])
    assert fixes == [] and parser.rejects["garbled"] == 1
