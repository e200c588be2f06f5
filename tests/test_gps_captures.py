"""The NMEA parser against 12 real receiver captures, with gpsd's decoded output as answer key.

Each ``.chk`` holds gpsd's JSON reports; every TPV object with mode >= 2 is a fix gpsd reported.
We must report at least 99 % of them in each capture and 99.5 % over all of them (lat/lon within
1e-6 deg and, when gpsd gives a time, the same UTC time of day within 1 ms), never a fix from a
sentence with a bad checksum, and never raise.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from sensors.cli import decode_nmea_file, strip_comment_lines
from sensors.gpsd_agreement import gpsd_fixes
from sensors.nmea import NmeaParser
from sensors.nmea_framing import with_checksum
from support.shared_data import shared_path

DATA = shared_path("nmea")
CAPTURES = sorted(DATA.glob("*.log"))
TOL_DEG = 1e-6

pytestmark = pytest.mark.shared_data("nmea")


def _time_of_day(iso: str) -> float:
    hh, mm, ss = iso[11:].rstrip("Z").split(":")
    return int(hh) * 3600 + int(mm) * 60 + float(ss)


def _matches(ref: dict, ours: list[dict]) -> bool:
    t = _time_of_day(ref["time"]) if "time" in ref else None
    for fix in ours:
        if abs(fix["lat"] - ref["lat"]) > TOL_DEG or abs(fix["lon"] - ref["lon"]) > TOL_DEG:
            continue
        if t is not None and (fix["utc_time_s"] is None or abs(fix["utc_time_s"] - t) > 1e-3):
            continue
        return True
    return False


def test_captures_present() -> None:
    assert len(CAPTURES) >= 12, f"{len(CAPTURES)} captures in {DATA}"


@pytest.mark.parametrize("capture", CAPTURES, ids=lambda p: p.name)
def test_capture_matches_gpsd(capture: Path) -> None:
    reference = gpsd_fixes(capture.with_name(capture.name + ".chk").read_text(errors="replace"))
    assert reference, "answer key has no fixes"
    records = list(decode_nmea_file(capture))
    summary = records[-1]
    ours = records[:-1]
    assert "counts" in summary and "rejects" in summary
    matched = sum(_matches(ref, ours) for ref in reference)
    ratio = matched / len(reference)
    print(f"{capture.name}: {matched}/{len(reference)} gpsd fixes matched ({ratio:.1%}), "
          f"{len(ours)} fixes reported, rejects {summary['rejects']}")
    assert ratio >= 0.99


def test_all_captures_match_gpsd_at_least_99_5_percent() -> None:
    """Issue 19.6: over all the shared captures together, >= 99.5 % of gpsd's fixes."""
    matched = total = 0
    for capture in CAPTURES:
        reference = gpsd_fixes(capture.with_name(capture.name + ".chk").read_text(errors="replace"))
        ours = list(decode_nmea_file(capture))[:-1]
        matched += sum(_matches(ref, ours) for ref in reference)
        total += len(reference)
    print(f"NMEA: {matched}/{total} of gpsd's fixes matched ({matched / total:.2%}) over "
          f"{len(CAPTURES)} captures")
    assert total > 400
    assert matched / total >= 0.995


def test_firefly_bad_checksums_give_no_fix() -> None:
    """firefly-II.log: every GGA has a bad checksum; fixes come from the RMCs only."""
    data = strip_comment_lines((DATA / "firefly-II.log").read_bytes())
    parser = NmeaParser()
    fixes = parser.feed(0.0, data) + parser.flush()
    assert parser.rejects["bad_checksum"] == 23
    assert fixes
    # GGA would set altitude, satellites and HDOP: none of that may leak into a fix.
    for fix in fixes:
        assert fix.satellites == 0
        assert fix.altitude_m != fix.altitude_m  # NaN


def test_corrupted_checksum_gives_no_fix() -> None:
    good = b"$GPGGA,143306.00,5546.83315,N,02334.72613,E,1,08,1.28,129.9,M,26.9,M,,*5B\r\n"
    bad = good.replace(b"*5B", b"*5C")
    parser = NmeaParser()
    assert parser.feed(0.0, bad) + parser.flush() == []
    assert parser.rejects["bad_checksum"] == 1
    parser = NmeaParser()
    fixes = parser.feed(0.0, good) + parser.flush()
    assert len(fixes) == 1
    assert fixes[0].lat_deg == pytest.approx(55.7805525, abs=1e-9)


@pytest.mark.parametrize("capture", CAPTURES, ids=lambda p: p.name)
def test_chunking_does_not_change_fixes(capture: Path) -> None:
    data = strip_comment_lines(capture.read_bytes())
    whole = NmeaParser()
    expected = whole.feed(0.0, data) + whole.flush()
    bytewise = NmeaParser()
    got = []
    for i in range(len(data)):
        got += bytewise.feed(0.0, data[i:i + 1])
    got += bytewise.flush()
    assert [(f.lat_deg, f.lon_deg, f.utc_time_s) for f in got] == [
        (f.lat_deg, f.lon_deg, f.utc_time_s) for f in expected]
    assert whole.rejects == bytewise.rejects


def _feed(*bodies: str) -> tuple[NmeaParser, list]:
    parser = NmeaParser()
    fixes = []
    for body in bodies:
        fixes += parser.feed(0.0, with_checksum(body))
    return parser, fixes + parser.flush()


def test_gsa_fix_mode_vouches_for_a_gga_counting_no_satellites() -> None:
    """Garmin 25LP and Furuno GN-8x (gpsd's garmin25lp.log, furuno_gl_ga.log): the GGA counts
    0 satellites in use, the GSA after it reports a 2D/3D fix and lists them; gpsd reports
    the fix, so must we, with the GGA's quality, HDOP and height."""
    _, fixes = _feed(
        "GPRMC,120325,V,4221.4394,N,01321.9948,E,000.0,000.0,150305,001.4,E",
        "GPGGA,120325,4221.4394,N,01321.9948,E,0,00,,,M,,M,,",
        "GPGSA,A,1,,,,,,,,,,,,,,,",
        "GPGSV,2,1,08,01,10,158,44,03,72,164,42,11,24,279,,14,30,119,48",
        "GPRMC,120326,A,4221.3871,N,01322.0800,E,000.0,000.0,150305,001.4,E",
        "GPGGA,120326,4221.3871,N,01322.0800,E,1,00,3.1,746.1,M,44.2,M,,",
        "GPGSA,A,2,01,03,,14,,,,,,,,,3.1,3.1,",
        "GPGSV,2,1,08,01,10,158,45,03,72,164,42,11,24,279,,14,30,119,48",
    )
    assert len(fixes) == 1
    fix = fixes[0]
    assert fix.lat_deg == pytest.approx(42.356451667, abs=1e-9)
    assert (fix.fix_quality, fix.satellites, fix.hdop, fix.altitude_m) == (1, 3, 3.1, 746.1)
    assert fix.utc_time_s == 12 * 3600 + 3 * 60 + 26


def test_gsa_no_fix_mode_withdraws_the_fix() -> None:
    """Once the cycle is learned, a GSA saying "no fix" (mode 1) withdraws the epoch's fix, as
    gpsd reports mode 1 then; a GSA with a fix mode but no position anywhere gives no fix."""
    cycle = ["GPGGA,1050{s}.80,5612.9956,N,00306.6983,W,1,5,2.5,160.0,M,,M,,",
             "GPGSA,A,{mode},29,30,9,12,5,,,,,,,,2.6,2.5,0.7",
             "GPGSV,1,1,02,29,47,187,36,30,80,98,33"]
    bodies = [line.format(s=s, mode=mode) for s, mode in (("27", 3), ("28", 3), ("29", 1),
                                                        ("30", 3)) for line in cycle]
    _, fixes = _feed(*bodies)
    assert [f.utc_time_s % 60 for f in fixes] == pytest.approx([27.8, 28.8, 30.8])
    _, fixes = _feed("GPRMC,105026.80,V,,,,,,,081009,,W,N",
                     "GPGSA,A,3,29,30,9,,,,,,,,,,2.5,2.5,0.6")
    assert fixes == []


def test_a_signed_coordinate_field_is_garbled_and_one_without_its_leading_zero_is_read() -> None:
    """The hemisphere letter carries the sign: a Unicore UM981 GLL writing the longitude as
    ``-0214.41467156,W`` (2 deg 14' W) is refused (gpsd reads it as 2.23 deg E; the old reader
    as 1.76 deg E), while ``1131.000,E`` (no leading zero) is 11 deg 31' E, as gpsd reads it."""
    parser, fixes = _feed("GNGLL,5327.03598945,N,-0214.41467156,W,130058.00,A,A")
    assert fixes == [] and parser.rejects["garbled"] == 1
    _, fixes = _feed("GPGLL,4807.038,N,1131.000,E,123519.00,A,A")
    assert [(f.lat_deg, f.lon_deg) for f in fixes] == [pytest.approx((48.1173, 11.5166667))]
    for bad in ("+4807.038", "48o7.038", "4.8e3", "4867.0"):
        parser, fixes = _feed(f"GPGLL,{bad},N,01131.000,E,123519.00,A,A")
        assert fixes == [] and parser.rejects["garbled"] == 1, bad
