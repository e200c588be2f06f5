"""The NMEA parser against 12 real receiver captures, with gpsd's decoded output as answer key.

Each ``.chk`` holds gpsd's JSON reports; every TPV object with mode >= 2 is a fix gpsd reported.
We must report at least 99 % of them (lat/lon within 1e-6 deg and, when gpsd gives a time, the
same UTC time of day within 1 ms), never a fix from a sentence with a bad checksum, and never
raise.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from sensors.cli import decode_nmea_file, strip_comment_lines
from sensors.nmea import NmeaParser
from support.shared_data import shared_path

DATA = shared_path("nmea")
CAPTURES = sorted(DATA.glob("*.log"))
TOL_DEG = 1e-6

pytestmark = pytest.mark.shared_data("nmea")


def _gpsd_fixes(chk: Path) -> list[dict]:
    fixes = []
    for line in chk.read_text(errors="replace").splitlines():
        if not line.startswith("{"):
            continue
        try:
            obj = json.loads(line)
        except json.JSONDecodeError:
            continue
        if obj.get("class") == "TPV" and obj.get("mode", 0) >= 2 and "lat" in obj:
            fixes.append(obj)
    return fixes


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
    reference = _gpsd_fixes(capture.with_name(capture.name + ".chk"))
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
