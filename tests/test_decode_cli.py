"""``python main.py decode ...``: JSON lines out, a final counts line, clear errors."""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import pytest

import main
from sensors.cli import strip_comment_lines
from support.shared_data import SHARED_DATA, missing, shared_data

DATA = SHARED_DATA


def _run(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, list[dict], str]:
    code = main.cli(argv)
    captured = capsys.readouterr()
    lines = [json.loads(line) for line in captured.out.splitlines() if line.strip()]
    return code, lines, captured.err


def _write_capture(tmp_path: Path) -> Path:
    path = tmp_path / "capture.log"
    path.write_bytes(
        b"# a comment line\n"
        b"$GPGGA,143306.00,5546.83315,N,02334.72613,E,1,08,1.28,129.9,M,26.9,M,,*5B\r\n"
        b"# another\r\n"
        b"\xb5\x62\x01\x07junk"
        b"$GPRMC,143306.50,A,5546.82983,N,02334.72123,E,30.324,221.16,091209,,,A*52\r\n"
        b"$GPGGA,143306.50,5546.82983,N,02334.72123,E,1,09,1.26,128.9,M,26.9,M,,*51\r\n")
    return path


def test_decode_nmea_prints_fixes_then_counts(tmp_path: Path,
                                              capsys: pytest.CaptureFixture[str]) -> None:
    code, lines, _ = _run(["decode", "nmea", str(_write_capture(tmp_path))], capsys)
    assert code == 0
    *fixes, summary = lines
    assert len(fixes) == 2
    assert fixes[0]["lat"] == pytest.approx(55.7805525, abs=1e-9)
    assert fixes[0]["lon"] == pytest.approx(23.578768833, abs=1e-9)
    assert fixes[0]["alt"] == pytest.approx(129.9)
    assert fixes[0]["sats"] == 8 and fixes[0]["quality"] == 1
    assert fixes[0]["time"] == "14:33:06.000"
    assert fixes[1]["speed_mps"] is None or math.isfinite(fixes[1]["speed_mps"])
    assert summary["rejects"]["bad_checksum"] == 1  # the last GGA's checksum is wrong
    assert summary["counts"]["fixes"] == 2


def test_decode_nmea_on_every_capture_never_fails(capsys: pytest.CaptureFixture[str]) -> None:
    captures = sorted((DATA / "nmea").glob("*.log"))
    if not captures:
        missing(str(DATA / "nmea" / "*.log"))
    for capture in captures:
        code, lines, _ = _run(["decode", "nmea", str(capture)], capsys)
        assert code == 0, capture.name
        assert "counts" in lines[-1] and "rejects" in lines[-1]
        assert all("lat" in line and "lon" in line for line in lines[:-1])


def test_comment_lines_only_at_line_start_are_dropped() -> None:
    data = b"#c\n$GPTXT,a#b*00\r\n#x\r\n\x00#\n"
    assert strip_comment_lines(data) == b"$GPTXT,a#b*00\r\n\x00#\n"


def test_missing_file_is_a_clear_error(capsys: pytest.CaptureFixture[str]) -> None:
    code, lines, err = _run(["decode", "nmea", "/nonexistent/file.log"], capsys)
    assert code == 2 and lines == []
    assert "no such file" in err


def test_missing_decoder_module_is_a_clear_error(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    dummy = tmp_path / "x.pcap"
    dummy.write_bytes(b"")
    monkeypatch.setitem(sys.modules, "sensors.decode_lidar", None)  # import raises
    code, _, err = _run(["decode", "lidar", str(dummy)], capsys)
    assert code == 2
    assert "sensors.decode_lidar" in err


def test_decode_can_and_lidar_dispatch(capsys: pytest.CaptureFixture[str]) -> None:
    log = shared_data("can", "comma2k19_rav4_bus0_candump.log")
    pcap = shared_data("lidar", "velodyne_vlp16.pcap")
    code, lines, _ = _run(["decode", "can", str(log)], capsys)
    assert code == 0 and "counts" in lines[-1]
    code, lines, _ = _run(["decode", "lidar", str(pcap)], capsys)
    assert code == 0 and "counts" in lines[-1]
