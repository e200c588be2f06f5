"""``bench gpsd``: our fixes against gpsd's, per receiver cycle, on captures with gpsd's answer
beside them (``.chk``) or played through gpsfake (issue 44)."""

from __future__ import annotations

import shutil
import stat
import subprocess
import sys
from pathlib import Path

import pytest

from sensors.gpsd_agreement import GpsfakeError, agreement, gpsd_cycles, gpsfake_reports
from sensors.nmea_framing import with_checksum
from support.shared_data import shared_path

ROOT = Path(__file__).resolve().parents[1]

GGA = "GPGGA,{t},4807.0380,N,01131.0000,E,1,08,0.9,545.4,M,46.9,M,,"
RMC = "GPRMC,{t},A,4807.0380,N,01131.0000,E,022.4,084.4,230394,003.1,W"


def _tpv(time_iso: str | None, lat: float = 48.1173, lon: float = 11.516666667,
         mode: int = 3) -> str:
    stamp = f'"time":"{time_iso}",' if time_iso else ""
    return f'{{"class":"TPV","mode":{mode},{stamp}"lat":{lat},"lon":{lon}}}'


def _capture(tmp_path: Path, seconds: list[int]) -> Path:
    lines = []
    for s in seconds:
        t = f"1235{s:02d}.00"
        lines += [with_checksum(GGA.format(t=t)), with_checksum(RMC.format(t=t))]
    path = tmp_path / "receiver.log"
    path.write_bytes(b"".join(lines))
    return path


def _bench(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "main.py", "bench", "gpsd", *args], cwd=ROOT,
                          capture_output=True, text=True, timeout=120)


def test_cycles_group_gpsd_reports_by_time() -> None:
    reports = "\n".join([
        "$GPGGA,...", _tpv(None),                              # before gpsd knew the date
        _tpv("1994-03-23T12:35:19.000Z"), _tpv("1994-03-23T12:35:19.000Z", lat=48.11731),
        _tpv("1994-03-23T12:35:20.000Z"), _tpv("1994-03-23T12:35:21.000Z", mode=1),
        '{"class":"SKY"}', "not json {",
    ])
    cycles = gpsd_cycles(reports)
    assert set(cycles) == {("untimed", 48.1173, 11.516667), 45319.0, 45320.0}
    assert len(cycles[45319.0]) == 2                        # one cycle, two positions


def test_a_fix_is_found_once_and_a_second_or_a_stray_one_is_extra() -> None:
    reports = "\n".join([_tpv("1994-03-23T12:35:19.000Z"), _tpv("1994-03-23T12:35:20.000Z")])
    fix = {"utc_time_s": 45319.0, "lat": 48.1173, "lon": 11.516666667}
    moved = {**fix, "utc_time_s": 45320.0, "lat": 48.2}          # right time, wrong place
    result = agreement(reports, [fix, dict(fix), moved])
    assert (result.cycles, result.found) == (2, 1)
    assert result.extra == [fix, moved]


@pytest.mark.shared_data("nmea")
def test_bench_on_the_shared_captures_finds_every_gpsd_cycle(tmp_path: Path) -> None:
    data = shared_path("nmea")
    for name in ("bu353s4.log", "hemi.log"):
        shutil.copy(data / name, tmp_path / name)
        shutil.copy(data / (name + ".chk"), tmp_path / (name + ".chk"))
    out = _bench(str(tmp_path / "bu353s4.log"), str(tmp_path / "hemi.log"))
    assert out.returncode == 0, out.stderr
    rows = [line.split() for line in out.stdout.splitlines()]
    assert any(r[:5] == ["bu353s4.log", "chk", "25", "25", "0"] for r in rows), out.stdout
    assert out.stdout.splitlines()[-1] == ("captures=2 failed=0 gpsd_cycles=31 found=31 "
                                           "extra=0 found_ratio=1.0000")


def test_bench_counts_what_gpsd_reported_and_we_did_not_and_the_reverse(tmp_path: Path) -> None:
    capture = _capture(tmp_path, [19, 20, 21, 22])
    # gpsd's answer: cycles 19 and 20 as we read them, 21 at another place, and one at 30 that
    # the capture does not hold; our fixes at 21 and 22 are extra (22: the last cycle, reported
    # when the capture ends)
    chk = [_tpv("1994-03-23T12:35:19.000Z"), _tpv("1994-03-23T12:35:20.000Z"),
           _tpv("1994-03-23T12:35:21.000Z", lat=48.3), _tpv("1994-03-23T12:35:30.000Z")]
    capture.with_name(capture.name + ".chk").write_text("\n".join(chk) + "\n")
    out = _bench(str(capture), "--show-extra", "5")
    assert out.returncode == 0, out.stderr
    assert out.stdout.count("    extra: ") == 2
    assert out.stdout.splitlines()[-1] == ("captures=1 failed=0 gpsd_cycles=4 found=2 extra=2 "
                                           "found_ratio=0.5000")


def test_without_an_answer_or_gpsfake_the_capture_fails_with_one_clear_line(
        tmp_path: Path) -> None:
    capture = _capture(tmp_path, [19, 20])
    out = _bench(str(capture), "--gpsfake", "no-such-gpsfake")
    assert out.returncode == 1
    assert "'no-such-gpsfake' not found: install gpsd's tools" in out.stderr
    assert out.stdout.splitlines()[-1].startswith("captures=0 failed=1 gpsd_cycles=0")
    missing = _bench(str(tmp_path / "nothing.log"))
    assert missing.returncode == 2 and "no such file" in missing.stderr


def _fake_gpsfake(tmp_path: Path, body: str) -> str:
    """A stand-in for gpsfake (unit test only): a script with gpsfake's interface."""
    script = tmp_path / "fake-gpsfake"
    script.write_text(f"#!{sys.executable}\nimport sys\n{body}\n")
    script.chmod(script.stat().st_mode | stat.S_IXUSR)
    return str(script)


def test_gpsfake_is_run_once_on_a_copy_at_38400_baud(tmp_path: Path) -> None:
    capture = _capture(tmp_path, [19])
    fake = _fake_gpsfake(tmp_path, (
        "args = sys.argv[1:]\n"
        "assert args[:4] == ['-1', '-p', '-s', '38400'], args\n"
        "assert args[4] != sys.argv[0] and open(args[4]).read().startswith('$GPGGA')\n"
        "print('{\"class\":\"VERSION\",\"release\":\"test\"}')\n"
        "print('{\"class\":\"TPV\",\"mode\":3,\"time\":\"1994-03-23T12:35:19.000Z\","
        "\"lat\":48.1173,\"lon\":11.516666667}')"))
    reports = gpsfake_reports(capture, fake)
    assert agreement(reports, [{"utc_time_s": 45319.0, "lat": 48.1173,
                                "lon": 11.516666667}]).found == 1
    broken = _fake_gpsfake(tmp_path, "print('gpsfake: zero-length packet', file=sys.stderr)\n"
                                     "sys.exit(1)")
    with pytest.raises(GpsfakeError, match="exit 1.*zero-length packet"):
        gpsfake_reports(capture, broken)
