"""Only the configured Velodyne's packets are decoded: the model from the factory bytes and the
packet timing; and the beam tables of sensors/lidar_models.py against velodyne-decoder's.

The shared capture (product id 0x21 with a VLP-16's 1327 us between packets: early VLP-16
firmware) must decode as today; copies of it with another model's id and timing written into
every packet (and the pcap records) must be refused, counted and logged in one line.
"""

from __future__ import annotations

import logging
import struct
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from sensors.decode_lidar import decode_pcap, read_pcap_udp
from sensors.lidar_parser import LidarParser
from sensors.velodyne_model import PACKET_PERIOD_US, ModelGuard, timing_model

ROOT = Path(__file__).resolve().parents[1]
PCAP = ROOT.parent / "shared" / "data" / "lidar" / "velodyne_vlp16.pcap"
needs_capture = pytest.mark.skipif(not PCAP.exists(), reason="shared test data missing")

STRONGEST, DUAL = 0x37, 0x39


def rewrite_capture(src: Path, dst: Path, product: int, period_us: float,
                    mode: int = STRONGEST) -> int:
    """Copy the pcap ``src`` to ``dst`` with every data packet's factory bytes set to ``mode``
    and ``product`` and its device timestamp (and the pcap record's time) ``period_us`` after
    the previous one's; returns the number of data packets rewritten."""
    data = bytearray(src.read_bytes())
    assert data[:4] == b"\xd4\xc3\xb2\xa1"  # little-endian, microsecond stamps
    offset, n = 24, 0
    t0_s = first_us = None
    while offset + 16 <= len(data):
        sec, usec, incl, _ = struct.unpack_from("<IIII", data, offset)
        frame = offset + 16
        end = frame + incl
        payload = end - 1206
        is_data = (incl >= 1206 + 42 and int.from_bytes(data[frame + 36:frame + 38], "big") == 2368
                   and data[payload:payload + 2] == b"\xff\xee")
        if is_data:
            if t0_s is None:
                t0_s = sec + usec * 1e-6
                first_us = int.from_bytes(data[payload + 1200:payload + 1204], "little")
            stamp_us = (first_us + round(n * period_us)) % 3_600_000_000  # type: ignore[operator]
            data[payload + 1200:payload + 1204] = stamp_us.to_bytes(4, "little")
            data[payload + 1204] = mode
            data[payload + 1205] = product
            t_us = round((t0_s + n * period_us * 1e-6) * 1e6)
            struct.pack_into("<II", data, offset, t_us // 1_000_000, t_us % 1_000_000)
            n += 1
        offset = end
    dst.write_bytes(bytes(data))
    return n


def _data_packets(path: Path) -> list[tuple[float, bytes]]:
    return [(t, p) for t, port, p in read_pcap_udp(path) if port == 2368 and len(p) == 1206]


@needs_capture
def test_shared_capture_is_a_vlp16_with_an_hdl32e_id(caplog: pytest.LogCaptureFixture) -> None:
    packets = _data_packets(PCAP)
    assert {(p[1204], p[1205]) for _, p in packets} == {(STRONGEST, 0x21)}
    with caplog.at_level(logging.WARNING):
        final = list(decode_pcap(str(PCAP)))[-1]
    assert final["rejects"] == {}
    assert "refused_models" not in final
    assert final["counts"]["data_packets"] == 84 and final["counts"]["sweeps"] >= 1
    assert not [r for r in caplog.records if "refusing" in r.getMessage()]


@needs_capture
@pytest.mark.parametrize(
    ("product", "period_us", "mode", "model"),
    [
        (0x21, PACKET_PERIOD_US["HDL-32E"], STRONGEST, "HDL-32E"),
        (0x21, PACKET_PERIOD_US["HDL-32E"] / 2, DUAL, "HDL-32E"),
        (0x22, PACKET_PERIOD_US["HDL-32E"], STRONGEST, "HDL-32E"),  # VLP-16 id, HDL timing
        (0x28, PACKET_PERIOD_US["VLP-32C"], STRONGEST, "VLP-32C"),
        (0x21, PACKET_PERIOD_US["VLP-32C"], STRONGEST, "VLP-32C"),  # HDL id, VLP-32C timing
        (0x24, PACKET_PERIOD_US["VLP-16"], STRONGEST, "Puck Hi-Res"),  # VLP-16 timing
        (0x00, PACKET_PERIOD_US["VLP-16"], STRONGEST, "unknown (product id 0x00)"),
    ],
)
def test_another_models_capture_is_refused_clearly(
        tmp_path: Path, caplog: pytest.LogCaptureFixture, product: int, period_us: float,
        mode: int, model: str) -> None:
    other = tmp_path / "other.pcap"
    n = rewrite_capture(PCAP, other, product, period_us, mode)
    assert n == 84
    points = tmp_path / "P.npy"
    with caplog.at_level(logging.WARNING):
        records = list(decode_pcap(str(other), str(points)))
    final = records[-1]
    assert records[:-1] == []  # no sweep, no cone
    assert final["rejects"] == {"wrong_model": 84}
    assert final["refused_models"] == {model: 84}
    assert final["counts"]["points_written"] == 0 and np.load(points).shape == (0, 4)
    lines = [r.getMessage() for r in caplog.records if "refusing" in r.getMessage()]
    assert len(lines) == 1 and model in lines[0] and "VLP-16" in lines[0], lines


@needs_capture
def test_cli_refuses_an_hdl32e_capture_in_one_line(tmp_path: Path) -> None:
    other = tmp_path / "hdl32e.pcap"
    rewrite_capture(PCAP, other, 0x21, PACKET_PERIOD_US["HDL-32E"])
    proc = subprocess.run([sys.executable, "main.py", "decode", "lidar", str(other)], cwd=ROOT,
                          capture_output=True, text=True, timeout=120, check=False)
    assert proc.returncode == 0, proc.stderr
    assert '"wrong_model": 84' in proc.stdout.splitlines()[-1]
    errors = proc.stderr.strip().splitlines()
    assert len(errors) == 1 and "HDL-32E" in errors[0] and "refusing" in errors[0], errors


@needs_capture
@pytest.mark.parametrize(("product", "mode"), [(0x21, DUAL), (0x22, STRONGEST)])
def test_vlp16_timing_is_accepted_with_either_id(tmp_path: Path, product: int,
                                                 mode: int) -> None:
    period = PACKET_PERIOD_US["VLP-16"] / (2 if mode == DUAL else 1)
    copy = tmp_path / "vlp16.pcap"
    rewrite_capture(PCAP, copy, product, period, mode)
    final = list(decode_pcap(str(copy), str(tmp_path / "P.npy")))[-1]
    assert final["rejects"] == {}
    assert final["counts"]["points_written"] > 0


def test_timing_model_periods_and_lost_packets() -> None:
    for k in (1, 2, 3, 4):
        assert timing_model(round(k * 1327.104), STRONGEST) == "VLP-16"
        assert timing_model(round(k * 663.552), DUAL) == "VLP-16"
    assert timing_model(553, STRONGEST) == "HDL-32E"
    assert timing_model(1106, STRONGEST) == "HDL-32E"
    assert timing_model(276, DUAL) == "HDL-32E"
    assert timing_model(664, STRONGEST) == "VLP-32C"
    for nothing in (0, -5, 1000, 1400, 10 * 1327):
        assert timing_model(nothing, STRONGEST) is None


def _packet(stamp_us: int, product: int = 0x21, mode: int = STRONGEST) -> bytes:
    body = bytearray(b"".join(b"\xff\xee" + bytes(98) for _ in range(12)))
    return bytes(body) + stamp_us.to_bytes(4, "little") + bytes([mode, product])


def test_guard_holds_the_first_ambiguous_packet_until_its_timing_is_known() -> None:
    guard: ModelGuard[int] = ModelGuard()
    assert guard.admit(0, _packet(1000)) == []  # 0x21 alone: could be either
    assert guard.admit(1, _packet(2327)) == [0, 1]  # 1327 us later: a VLP-16, both decoded
    assert guard.admit(2, _packet(900_000)) == [2]  # a gap tells nothing: the verdict stands
    assert guard.refused == {}
    lone: ModelGuard[int] = ModelGuard()
    assert lone.admit(0, _packet(1000)) == []
    assert lone.flush() == []  # its timing was never seen: refused, not guessed
    assert lone.refused == {"HDL-32E": 1}


def test_guard_takes_a_vlp16_id_unless_the_timing_contradicts() -> None:
    alone: ModelGuard[int] = ModelGuard()
    assert alone.admit(0, _packet(0, product=0x22)) == []
    assert alone.admit(1, _packet(500_000, product=0x22)) == [0]  # a gap: by its id
    assert alone.flush() == [1]
    guard: ModelGuard[int] = ModelGuard()
    assert guard.admit(0, _packet(0, product=0x22)) == []  # held until the timing is seen
    assert guard.admit(1, _packet(553, product=0x22)) == []
    assert guard.admit(2, _packet(1106, product=0x22)) == []
    assert guard.refused == {"HDL-32E": 3}
    assert guard.admit(3, _packet(1106 + 1327, product=0x22)) == [3]  # the timing says VLP-16


def test_unknown_return_mode_is_refused() -> None:
    guard: ModelGuard[int] = ModelGuard()
    assert guard.admit(0, _packet(0, product=0x22, mode=0x00)) == []
    assert list(guard.refused) == ["unknown (return mode byte 0x00)"]


def test_simulated_packets_with_losses_are_all_decoded() -> None:
    """The simulator's VLP-16 (id 0x22, 1327 us, some packets lost) is never refused."""
    from types import SimpleNamespace

    from common.messages import GroundTruth
    from orchestrator.config import AppConfig
    from simulator.lidar_model import LidarModel

    config = AppConfig()
    model = LidarModel(config, np.random.default_rng(4))
    track = SimpleNamespace(cones_xy_m=np.array([[6.0, 1.5], [6.0, -1.5]]), sizes=np.array([1, 1]))
    parser = LidarParser(config.sensors.lidar, config.car)
    fed = 0
    for i in range(1, 101):
        t = i * 0.005
        for raw in model.poll(t, GroundTruth(t, 0, 0, 0, 0, 0, 0), None, track):
            if fed % 7 != 3:  # lose one packet in seven
                parser.feed(raw.timestamp_s, raw.payload)
            fed += 1
    parser.flush()
    assert parser.rejects == {}
    assert parser.counts["packets"] == fed - sum(1 for k in range(fed) if k % 7 == 3)


def _velodyne_decoder_calibration(model: str, bundled: bool) -> list[dict[str, float]]:
    """The lasers of velodyne-decoder's calibration of ``model`` (``"HDL32E"``, ``"VLP32C"``):
    the one its decoder uses (``Calibration.default_calibs``) or the bundled YAML file."""
    import velodyne_decoder as vd
    import yaml
    if bundled:
        name = {"HDL32E": "HDL-32E.yml", "VLP32C": "VLP-32C.yml"}[model]
        calibration = vd.calibrations.get_bundled_calibration(name)
    else:
        calibration = vd.Calibration.default_calibs[getattr(vd.Model, model)]
    lasers: list[dict[str, float]] = yaml.safe_load(calibration.to_string())["lasers"]
    return sorted(lasers, key=lambda laser: laser["laser_id"])


@pytest.mark.parametrize("bundled", [False, True])
@pytest.mark.parametrize(("vd_model", "ours"), [("HDL32E", "hdl32e"), ("VLP32C", "vlp32c")])
def test_beam_tables_match_velodyne_decoders_calibrations(vd_model: str, ours: str,
                                                          bundled: bool) -> None:
    from sensors.lidar_models import LIDAR_MODELS
    lasers = _velodyne_decoder_calibration(vd_model, bundled)
    theirs = np.degrees([laser["vert_correction"] for laser in lasers])
    table = np.asarray(LIDAR_MODELS[ours].beam_elevation_deg)
    assert table.shape == theirs.shape == (32,)
    np.testing.assert_allclose(table, theirs, atol=1e-4)  # their radians are float32
    # the table is the manuals' to the hundredth (HDL-32E) or thousandth (VLP-32C): exact
    decimals = 2 if ours == "hdl32e" else 3
    np.testing.assert_array_equal(table, np.round(theirs, decimals))


def test_hdl32e_vertical_offsets_match_velodyne_decoder() -> None:
    from sensors.hdl32e import VERTICAL_OFFSET_M
    lasers = _velodyne_decoder_calibration("HDL32E", bundled=False)
    np.testing.assert_allclose(VERTICAL_OFFSET_M,
                               [laser["vert_offset_correction"] for laser in lasers], atol=1e-8)
