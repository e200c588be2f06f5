"""HDL-32E packet decoding against velodyne-decoder, on the real capture in ../shared/data; its
packets refused when a VLP-16 is configured and the other way round; truncated packets."""

from __future__ import annotations

import json
import logging
from pathlib import Path

import numpy as np
import pytest

import main
from sensors.config import LidarConfig
from sensors.decode_lidar import decode_pcap, iter_pcap_sweeps, read_pcap_udp
from sensors.hdl32e import HDL32E_LAYOUT
from sensors.lidar_models import LIDAR_MODELS
from sensors.lidar_parser import LidarParser
from sensors.velodyne import decode_packets
from support.shared_data import shared_data, shared_path
from support.velodyne_reference import velodyne_decoder_points

PCAP = shared_path("lidar", "velodyne_hdl32e.pcap")
DATA_PACKETS = 876

pytestmark = pytest.mark.shared_data("lidar/velodyne_hdl32e.pcap")


def _data_packets() -> list[tuple[float, bytes]]:
    return [(t, p) for t, port, p in read_pcap_udp(PCAP) if port == 2368 and len(p) == 1206]


def _reference() -> np.ndarray:
    """Every return as velodyne-decoder decodes it with its HDL-32E model and calibration:
    x, y, z, intensity, time, column, ring, return type."""
    return velodyne_decoder_points(_data_packets(), "HDL32E")


def test_cli_decode_lidar_hdl32e_matches_velodyne_decoder(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "P.npy"
    code = main.cli(["decode", "lidar", str(PCAP), "--lidar", "hdl32e", "--points-out", str(out)])
    lines = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    assert code == 0
    final = lines[-1]
    assert final["counts"]["data_packets"] == DATA_PACKETS
    assert final["counts"]["position_packets"] == 100
    assert final["rejects"] == {} and "refused_models" not in final
    assert final["counts"]["sweeps"] == len(lines) - 1 >= 2
    ours = np.load(out)
    ref = _reference()
    # every return, in the same order (packet, block, laser): x, y, z within 1 mm, 100 %
    assert ours.shape == (ref.shape[0], 4) and ref.shape[0] > 250_000
    err = np.linalg.norm(ours[:, :3] - ref[:, :3], axis=1)
    assert err.max() < 1e-3
    np.testing.assert_array_equal(ours[:, 3], ref[:, 3])
    # rings (0 = lowest laser) agree too
    dec = decode_packets([p for _, p in _data_packets()], layout=HDL32E_LAYOUT)
    np.testing.assert_array_equal(dec.rings, ref[:, 6].astype(np.int64))


def test_layout_is_the_manuals() -> None:
    np.testing.assert_array_equal(HDL32E_LAYOUT.elevation_deg,
                                  LIDAR_MODELS["hdl32e"].beam_elevation_deg)
    # one firing sequence of 32 lasers 1.152 us apart per block, 46.08 us a block
    t = HDL32E_LAYOUT.return_time_s.astype(np.float64)
    expected = 46.08e-6 * np.arange(12)[:, None] + 1.152e-6 * np.arange(32)[None, :]
    np.testing.assert_allclose(t, expected, atol=1e-10)
    assert HDL32E_LAYOUT.packet_duration_s == pytest.approx(552.96e-6)
    assert HDL32E_LAYOUT.laser_ring[0] == 0 and HDL32E_LAYOUT.laser_ring[31] == 31


def test_sweeps_one_at_a_time() -> None:
    sweeps = list(iter_pcap_sweeps(PCAP, "hdl32e"))
    total = decode_packets([p for _, p in _data_packets()], layout=HDL32E_LAYOUT).points
    assert sum(s[0].shape[0] for s in sweeps) == total.shape[0]  # each return in one sweep
    full = sweeps[1]  # the first starts mid-turn: the capture begins at azimuth 215 deg
    points, rings, times, end_s = full
    assert points.dtype == np.float64 and points.shape[1] == 4
    assert rings.dtype == np.int64 and set(np.unique(rings)) == set(range(32))
    assert times.shape == rings.shape and end_s == pytest.approx(times.max())
    assert 0.08 < times.max() - times.min() < 0.09  # a turn: this unit spins at 11.7 Hz
    assert np.all(np.diff(times) >= -1e-6)
    azimuth = np.degrees(np.arctan2(-points[:, 1], points[:, 0])) % 360.0
    rel = (azimuth - 180.0) % 360.0  # cut behind the car
    assert rel.min() < 1.0 and rel.max() > 359.0


def test_hdl32e_refused_as_a_vlp16_and_vlp16_as_an_hdl32e(
        tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    with caplog.at_level(logging.WARNING):
        final = list(decode_pcap(str(PCAP), str(tmp_path / "P.npy")))  # default: VLP-16
    assert final[:-1] == []
    assert final[-1]["rejects"] == {"wrong_model": DATA_PACKETS}
    assert final[-1]["refused_models"] == {"HDL-32E": DATA_PACKETS}
    assert np.load(tmp_path / "P.npy").shape == (0, 4)
    lines = [r.getMessage() for r in caplog.records if "refusing" in r.getMessage()]
    assert len(lines) == 1 and "HDL-32E" in lines[0]
    vlp16 = shared_data("lidar", "velodyne_vlp16.pcap")  # 0x21 with a VLP-16's timing
    final = list(decode_pcap(str(vlp16), model="hdl32e"))
    assert final[-1]["rejects"] == {"wrong_model": 84}
    assert final[-1]["refused_models"] == {"VLP-16": 84}


def test_truncated_packets_and_records_are_counted(tmp_path: Path) -> None:
    packets = _data_packets()
    parser = LidarParser(LidarConfig(model="hdl32e"), all_points=True)
    for k, (stamp, payload) in enumerate(packets[:40]):
        data = payload[:700] if k % 10 == 5 else payload
        parser.feed(stamp, data)
    parser.flush()
    assert parser.rejects == {"bad_length": 4}
    assert parser.counts["packets"] == 36
    # a capture cut in the middle of a record: the records before it decode
    data = PCAP.read_bytes()
    cut = tmp_path / "cut.pcap"
    cut.write_bytes(data[:len(data) // 2])
    final = list(decode_pcap(str(cut), model="hdl32e"))[-1]
    assert final["counts"]["truncated_record"] == 1
    assert 400 < final["counts"]["data_packets"] < DATA_PACKETS
    assert final["rejects"] == {}
