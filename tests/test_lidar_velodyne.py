"""VLP-16 packet decoding against velodyne-decoder, on the real capture in ../shared/data."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from common.errors import DecodeError
from sensors.decode_lidar import decode_pcap, read_pcap_udp
from sensors.lidar_parser import LidarParser
from sensors.velodyne import (
    PACKET_SIZE,
    SweepAssembler,
    decode_packet,
    decode_packets,
)
from support.shared_data import shared_path
from support.velodyne_reference import velodyne_decoder_points

ROOT = Path(__file__).resolve().parents[1]
PCAP = shared_path("lidar", "velodyne_vlp16.pcap")

pytestmark = pytest.mark.shared_data("lidar/velodyne_vlp16.pcap")


def _data_packets() -> list[tuple[float, bytes]]:
    return [(t, p) for t, port, p in read_pcap_udp(PCAP) if port == 2368 and len(p) == 1206]


def _reference_points() -> np.ndarray:
    """Every return as velodyne-decoder decodes it with its VLP-16 model and calibration.

    The capture's product-id byte says 0x21 (HDL-32E) although the data is a VLP-16's (16 lasers,
    0.2 deg per firing, 2 firings per block); velodyne-decoder refuses a VLP-16 model with that
    id, so the reference is given the packets with the id byte set to 0x22 (VLP-16).
    """
    return velodyne_decoder_points(_data_packets(), "VLP16", product_id=0x22)


def test_decode_pcap_points_match_velodyne_decoder(tmp_path: Path) -> None:
    out = tmp_path / "P.npy"
    records = list(decode_pcap(str(PCAP), str(out)))
    counts = records[-1]["counts"]
    assert counts["data_packets"] == 84
    assert counts["position_packets"] == 16
    assert records[-1]["rejects"] == {}
    ours = np.load(out)
    ref = _reference_points()
    assert ours.shape == (ref.shape[0], 4)
    # the same returns in the same order (packet, block, firing, laser): x, y, z within 1 mm
    err = np.linalg.norm(ours[:, :3] - ref[:, :3], axis=1)
    assert err.max() < 1e-3
    np.testing.assert_array_equal(ours[:, 3], ref[:, 3])
    # rings (0 = lowest laser) and per-return times agree too
    dec = decode_packets([p for _, p in _data_packets()])
    np.testing.assert_array_equal(dec.rings, ref[:, 6].astype(np.int64))


def test_cli_decode_lidar_writes_points(tmp_path: Path) -> None:
    out = tmp_path / "P.npy"
    proc = subprocess.run(
        [sys.executable, "main.py", "decode", "lidar", str(PCAP), "--points-out", str(out)],
        cwd=ROOT, capture_output=True, text=True, timeout=120,
    )
    assert proc.returncode == 0, proc.stderr
    ref = _reference_points()
    ours = np.load(out)
    assert ours.shape[0] == ref.shape[0]
    assert np.linalg.norm(ours[:, :3] - ref[:, :3], axis=1).max() < 1e-3


def test_single_packet_decode_and_time_offsets() -> None:
    payload = _data_packets()[0][1]
    points, azimuth, rings, dt = decode_packet(payload)
    assert points.shape[1] == 4 and points.shape[0] == azimuth.shape[0] == rings.shape[0]
    assert rings.min() >= 0 and rings.max() <= 15
    # 12 blocks x 2 firings x 55.296 us, lasers 2.304 us apart
    assert 0.0 <= dt.min() and dt.max() <= 23 * 55.296e-6 + 15 * 2.304e-6 + 1e-9
    # azimuth grows through the packet (no wrap in the first packet)
    assert np.all(np.diff(azimuth[rings == 0]) > 0)


@pytest.mark.parametrize(
    ("mangle", "reason"),
    [
        (lambda p: p[:1000], "bad_length"),
        (lambda p: p + b"\x00", "bad_length"),
        (lambda p: p[:500] + b"\x00\x00" + p[502:], "bad_flag"),
        (lambda p: p[:2] + (40000).to_bytes(2, "little") + p[4:], "bad_azimuth"),
    ],
)
def test_bad_packets_raise_and_are_counted(mangle: object, reason: str) -> None:
    payload = _data_packets()[0][1]
    bad = mangle(payload)  # type: ignore[operator]
    with pytest.raises(DecodeError):
        decode_packet(bad)
    parser = LidarParser()
    assert parser.feed(0.0, bad) == []
    assert parser.rejects[reason] == 1


def test_garbage_never_raises_from_parser() -> None:
    rng = np.random.default_rng(3)
    parser = LidarParser()
    for i in range(50):
        n = int(rng.choice([0, 10, 512, PACKET_SIZE, 2000]))
        parser.feed(i * 0.001, rng.integers(0, 256, n, dtype=np.uint8).tobytes())
    assert sum(parser.rejects.values()) == 50


def test_sweep_assembler_cuts_at_azimuth_and_keeps_every_return() -> None:
    packets = _data_packets()
    total = decode_packets([p for _, p in packets]).points.shape[0]
    for cut in (0.0, 90.0, 180.0, 250.6):
        asm = SweepAssembler(cut_azimuth_deg=cut)
        sweeps = []
        for stamp, payload in packets:
            sweeps.extend(asm.add(stamp, payload))
        sweeps.extend(asm.flush())
        assert sum(s.points.shape[0] for s in sweeps) == total
        # inside each sweep, azimuths measured from the cut never decrease by much
        for s in sweeps:
            az = (np.degrees(np.arctan2(-s.points[:, 1], s.points[:, 0])) - cut) % 360.0
            ring0 = az[s.rings == 0]
            assert np.all(np.diff(ring0) > -1.0)
            assert np.all(np.diff(s.times_s) >= -1e-6)


def test_simulated_packets_over_udp_loopback_give_cones() -> None:
    """Simulated packets sent over UDP on loopback, received and parsed into cones."""
    import socket
    from types import SimpleNamespace

    from common.messages import GroundTruth
    from orchestrator.config import AppConfig
    from simulator.lidar_model import LidarModel

    config = AppConfig()
    model = LidarModel(config, np.random.default_rng(9))
    track = SimpleNamespace(cones_xy_m=np.array([[6.0, 1.5], [6.0, -1.5], [9.0, 1.5]]),
                            sizes=np.array([1, 1, 2]))
    raws = []
    for i in range(1, 51):
        t = i * 0.005
        raws.extend(model.poll(t, GroundTruth(t, 0, 0, 0, 0, 0, 0), None, track))
    rx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    tx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    rx.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1 << 20)
    rx.bind(("127.0.0.1", 0))
    rx.settimeout(2.0)
    parser = LidarParser(config.sensors.lidar, config.car)
    out = []
    try:
        for raw in raws:
            tx.sendto(raw.payload, rx.getsockname())
            data, _ = rx.recvfrom(2048)
            out.extend(parser.feed(raw.timestamp_s, data))
    finally:
        rx.close()
        tx.close()
    out.extend(parser.flush())
    assert parser.rejects == {}
    full = out[1] if len(out) > 1 else out[0]
    found = sorted((round(c.x_m), round(c.y_m, 1)) for c in full.cones)
    assert found == [(6, -1.5), (6, 1.5), (9, 1.5)]
