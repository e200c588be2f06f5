"""comma2k19's real drive localised with a GNSS latency from the drive itself (issue 44).

The importer writes no latency; ``replay`` estimates it from the recording's own fixes and
wheels (no reference), says so in ``summary.json`` (``gnss_latency_source``: ``estimated``, with
its sigma), and still meets issue 17's acceptance against comma's pose; a latency set in the
configuration wins (``configured``).
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from main import cli
from orchestrator.log_import import GnssOutage, import_log
from recordings.importers import comma2k19
from support.shared_data import shared_data

SEGMENT = ("vehicle_logs", "comma2k19_rav4_seg40")

pytestmark = pytest.mark.shared_data("vehicle_logs/comma2k19_rav4_seg40")


@pytest.fixture(scope="module")
def recording(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("c2k19") / "seg40.mcap"
    import_log("comma2k19", shared_data(*SEGMENT), path, GnssOutage(25.0, 10.0))
    return path


def _replay(recording: Path, out: Path, *extra: str) -> dict:
    assert cli(["replay", str(recording), "--out", str(out), *extra]) == 0
    return json.loads((out / "summary.json").read_text())  # type: ignore[no-any-return]


def test_importer_writes_no_latency() -> None:
    log = comma2k19.load(shared_data(*SEGMENT))
    assert "gnss_latency_s" not in log.config["mapper"]["ukf"]
    assert log.config["mapper"]["ukf"]["gnss_time_from_utc"] is True


def test_latency_estimated_from_the_drive(recording: Path, tmp_path: Path) -> None:
    summary = _replay(recording, tmp_path / "out")
    assert summary["gnss_latency_source"] == "estimated"
    # comma's pose put it at about 0.06 s (0.04 s: 0.53 m RMS, 0.06: 0.41, 0.08: 0.54)
    assert 0.04 <= summary["gnss_latency_s"] <= 0.08
    assert 0.0 < summary["gnss_latency_sigma_s"] <= 0.02
    assert summary["gnss_latency_estimate"]["pairs"] > 300
    assert summary["position_rmse_m"] <= 0.45
    assert summary["heading_rmse_deg"] <= 0.30
    assert summary["gnss_outage"]["max_error_m"] <= 2.0


def test_configured_latency_wins(recording: Path, tmp_path: Path) -> None:
    config = tmp_path / "latency.toml"
    config.write_text("[mapper.ukf]\ngnss_latency_s = 0.05\n")
    summary = _replay(recording, tmp_path / "out", "--config", str(config))
    assert summary["gnss_latency_source"] == "configured"
    assert summary["gnss_latency_s"] == 0.05
    assert "gnss_latency_sigma_s" not in summary
