"""Ouster OS1-64 legacy packets: decoded as ouster-sdk decodes them, on the real capture and its
early metadata file in ../shared/data; sweeps a frame at a time; metadata that lacks keys,
truncated packets and another sensor's packets give one clear error or a counted rejection."""

from __future__ import annotations

import json
import logging
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import main
from common.errors import ConfigError
from sensors.config import LidarConfig
from sensors.decode_lidar import decode_pcap, iter_pcap_sweeps, read_pcap_udp
from sensors.lidar_parser import LidarParser
from sensors.ouster import OusterGeometry, decode_packets, load_meta, parse_meta
from support.shared_data import shared_data, shared_path

PCAP = shared_path("lidar", "ouster_example.pcap")
META = shared_path("lidar", "ouster_example.json")
RETURNS = 92270
"""Returns (range > 0) in the capture's 100 packets."""

pytestmark = pytest.mark.shared_data("lidar/ouster_example.pcap", "lidar/ouster_example.json")


def _packets() -> list[tuple[float, bytes]]:
    return [(t, p) for t, port, p in read_pcap_udp(PCAP) if port == 7502]


def _meta_json() -> dict[str, Any]:
    return json.loads(META.read_text())


def _sdk_frames() -> dict[int, tuple[np.ndarray, np.ndarray]]:
    """ouster-sdk's decoding of the capture: per frame id, the range image (h, w) and its
    ``XYZLut`` points (h, w, 3), m, sensor frame."""
    pytest.importorskip("ouster.sdk")
    from ouster.sdk import core as sdk_core
    from ouster.sdk import pcap
    core: Any = sdk_core  # (its stubs lack some names)
    info = core.SensorInfo(META.read_text())
    batcher = core.FrameBatcher(info)
    lut = core.XYZLut(info)
    frames: dict[int, tuple[np.ndarray, np.ndarray]] = {}
    frame = core.LidarFrame(info)

    def keep(f: Any) -> None:
        frames[int(f.frame_id)] = (np.array(f.field(core.ChanField.RANGE)), np.array(lut(f)))

    for _, packet in pcap.PcapPacketSource(str(PCAP), sensor_info=[info]):
        if batcher.batch(packet, frame):
            keep(frame)
            frame = core.LidarFrame(info)
    keep(frame)  # the last, partial frame
    return frames


def test_early_metadata_file_takes_ouster_sdks_defaults() -> None:
    meta = load_meta(META)
    assert meta.beams == 64 and meta.columns_per_frame == 1024 and meta.rotation_hz == 10.0
    assert meta.columns_per_packet == 16 and meta.packet_size == 12608
    np.testing.assert_array_equal(meta.lidar_to_sensor, [[-1, 0, 0, 0], [0, -1, 0, 0],
                                                         [0, 0, 1, 36.18], [0, 0, 0, 1]])
    assert meta.beam_to_lidar[0, 3] == 12.163  # the beam origin offset, mm
    geometry = OusterGeometry(meta)
    assert geometry.laser_ring[0] == 63 and geometry.laser_ring[63] == 0  # beam 0 the highest
    # column 0 looks backwards (the connector), column 512 forwards
    assert geometry.column_azimuth_deg[0] == pytest.approx(180.0)
    assert geometry.first_column_from(0.0) == 512 and geometry.first_column_from(180.0) == 0


def test_cli_decode_lidar_os1_matches_ouster_sdk(tmp_path: Path,
                                                  capsys: pytest.CaptureFixture[str]) -> None:
    frames = _sdk_frames()
    out = tmp_path / "P.npy"
    code = main.cli(["decode", "lidar", str(PCAP), "--lidar", "os1-64", "--meta", str(META),
                     "--points-out", str(out)])
    lines = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    assert code == 0
    final = lines[-1]
    assert final["counts"]["data_packets"] == 100 and final["rejects"] == {}
    assert [s["points"] for s in lines[:-1]] == [12783, 58797, 20690]  # frame by frame
    ours = np.load(out)
    assert ours.shape == (RETURNS, 4)
    assert sum(int((rng > 0).sum()) for rng, _ in frames.values()) == RETURNS
    # the same returns: each of ours at its (frame, column, beam) in ouster-sdk's images
    dec = decode_packets([p for _, p in _packets()], OusterGeometry(load_meta(META)))
    np.testing.assert_array_equal(dec.points, ours)
    ref = np.empty((RETURNS, 3))
    for frame_id, (rng, xyz) in frames.items():
        mine = dec.frame_id == frame_id
        assert np.all(rng[dec.beam[mine], dec.measurement_id[mine]] > 0)
        ref[mine] = xyz[dec.beam[mine], dec.measurement_id[mine]]
    err = np.linalg.norm(ours[:, :3] - ref, axis=1)
    assert np.mean(err < 1e-3) >= 0.999
    assert err.max() < 1e-6  # in fact the same arithmetic: all of them


def test_sweeps_are_the_sensors_frames() -> None:
    sweeps = list(iter_pcap_sweeps(PCAP, "os1-64", META))
    assert [s[0].shape[0] for s in sweeps] == [12783, 58797, 20690]
    points, rings, times, end_s = sweeps[1]  # frame 12073, complete
    assert points.dtype == np.float64 and rings.dtype == np.int64
    assert set(np.unique(rings)) == set(range(64))
    assert times.shape == rings.shape and end_s >= times.max()
    # 1024 columns at 10 Hz, stamped by the sensor: 0.1 s less one column
    assert times.max() - times.min() == pytest.approx(0.1, abs=2e-3)
    assert abs(end_s - _packets()[77][0]) < 0.01  # on the capture's clock
    # cut ahead of the car instead, at column 512: the capture (frame 12072 column 800 to
    # frame 12074 column 351) makes two sweeps, the first ending there, the second from there
    ahead = list(iter_pcap_sweeps(PCAP, "os1-64", str(META), cut_azimuth_deg=0.0))
    assert sum(s[0].shape[0] for s in ahead) == RETURNS and len(ahead) == 2
    first, second = (np.degrees(np.arctan2(-s[0][:, 1], s[0][:, 0])) % 360.0 for s in ahead)
    # (a beam looks up to 3.3 deg beside its column)
    assert np.percentile(first, 99) > 353.0 and np.percentile(second, 1) < 7.0


def test_metadata_errors_are_one_clear_line(tmp_path: Path,
                                            capsys: pytest.CaptureFixture[str]) -> None:
    def broken(**changes: Any) -> Path:
        obj = _meta_json()
        for key, value in changes.items():
            if value is None:
                obj.pop(key)
            else:
                obj[key] = value
        path = tmp_path / f"meta{len(list(tmp_path.iterdir()))}.json"
        path.write_text(json.dumps(obj))
        return path

    cases = [
        (broken(beam_altitude_angles=None), "beam_altitude_angles"),
        (broken(beam_azimuth_angles=[1.0, 2.0]), "azimuth"),
        (broken(lidar_mode=None), "lidar_mode"),
        (broken(lidar_mode="fast"), "lidar_mode"),
        (broken(beam_altitude_angles=["a"] * 64), "beam_altitude_angles"),
        (broken(lidar_to_sensor_transform=[1, 2, 3]), "lidar_to_sensor_transform"),
        (broken(data_format={"udp_profile_lidar": "RNG19_RFL8_SIG16_NIR16"}), "LEGACY"),
    ]
    for path, key in cases:
        with pytest.raises(ConfigError, match=key):
            load_meta(path)
        code = main.cli(["decode", "lidar", str(PCAP), "--lidar", "os1-64", "--meta", str(path)])
        err = capsys.readouterr().err.strip().splitlines()
        assert code == 2 and len(err) == 1 and err[0].startswith("error:") and key in err[0]
    (tmp_path / "bad.json").write_text("{not json")
    with pytest.raises(ConfigError, match="not JSON"):
        load_meta(tmp_path / "bad.json")
    with pytest.raises(ConfigError, match="32 beams"):
        LidarParser(LidarConfig(model="os1-64", meta_file=str(broken(
            beam_altitude_angles=[0.0] * 32, beam_azimuth_angles=[0.0] * 32))))
    code = main.cli(["decode", "lidar", str(PCAP), "--lidar", "os1-64"])  # no --meta
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "meta" in err[0]


def test_later_metadata_layouts_read_alike() -> None:
    early = _meta_json()
    nested = {
        "beam_intrinsics": {"beam_altitude_angles": early["beam_altitude_angles"],
                            "beam_azimuth_angles": early["beam_azimuth_angles"],
                            "lidar_origin_to_beam_origin_mm": 12.163},
        "lidar_intrinsics": {"lidar_to_sensor_transform": [-1, 0, 0, 0, 0, -1, 0, 0,
                                                           0, 0, 1, 36.18, 0, 0, 0, 1]},
        "config_params": {"lidar_mode": "1024x10", "udp_profile_lidar": "LEGACY"},
        "lidar_data_format": {"columns_per_packet": 16, "pixels_per_column": 64,
                              "columns_per_frame": 1024},
    }
    a, b = OusterGeometry(parse_meta(early)), OusterGeometry(parse_meta(nested))
    np.testing.assert_array_equal(a.direction, b.direction)
    np.testing.assert_array_equal(a.offset, b.offset)


def test_truncated_garbage_and_other_sensors_packets_are_counted(
        caplog: pytest.LogCaptureFixture) -> None:
    packets = _packets()
    parser = LidarParser(LidarConfig(model="os1-64", meta_file=str(META)), all_points=True)
    vlp16 = [p for _, port, p in read_pcap_udp(shared_data("lidar", "velodyne_vlp16.pcap"))
             if port == 2368]
    bad_ids = bytearray(packets[3][1])
    bad_ids[8 + 788 * 5] ^= 0x40  # column 5's measurement id no longer follows column 4's
    rng = np.random.default_rng(5)
    with caplog.at_level(logging.WARNING):
        for k, (stamp, payload) in enumerate(packets):
            parser.feed(stamp, payload[:5000] if k == 10 else payload)
        parser.feed(1.0, vlp16[0])  # a Velodyne's data packet
        parser.feed(1.0, bytes(16 * (20 + 12 * 16)))  # an OS1-16's packet size
        parser.feed(1.0, bytes(bad_ids))
        for size in (0, 48, 12607, 12608, 12609):
            parser.feed(1.0, rng.integers(0, 256, size, dtype=np.uint8).tobytes())
        parser.flush()
    assert parser.rejects["bad_length"] == 5
    assert parser.rejects["wrong_model"] == 2
    assert parser.rejects["bad_column"] >= 1
    assert parser.refused == {"Velodyne HDL-32E": 1, "Ouster OS1 (16 beams, legacy packets)": 1}
    assert parser.counts["packets"] == 99 + 1 - parser.rejects["bad_column"] + 1
    assert any("Velodyne HDL-32E" in r.getMessage() for r in caplog.records)
    # and the VLP-16's parser refuses the Ouster's packets
    final = list(decode_pcap(str(PCAP)))[-1]
    assert final["rejects"] == {"wrong_model": 100}
    assert final["refused_models"] == {"Ouster OS1 (64 beams, legacy packets)": 100}


def test_live_receiver_decodes_the_ouster_over_udp() -> None:
    """The car's LiDAR receiver built from the config (lidar.model os1-64) on loopback."""
    import socket
    import time

    from common.car import CarConfig
    from common.clock import RealClock
    from sensors.udp_receiver import lidar_receiver

    clock = RealClock()
    config = LidarConfig(model="os1-64", meta_file=str(META))
    receiver = lidar_receiver(clock, config, CarConfig(), "127.0.0.1", 0, read_timeout_s=0.02)
    packets = [p for _, p in _packets()]
    with receiver:
        assert receiver.wait_connected(5.0) and receiver.bound_address is not None
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
            for k, payload in enumerate([*packets, packets[0][:100]]):
                sock.sendto(payload, receiver.bound_address)
                if k % 10 == 9:
                    time.sleep(0.005)  # 10 packets a 5 ms: twice the sensor's rate
        deadline = time.monotonic() + 5.0
        while receiver.intake.raw_count < len(packets) + 1 and time.monotonic() < deadline:
            time.sleep(0.02)
        _, readings = receiver.intake.take()
        parser: Any = receiver.intake.parser
        assert parser.counts["packets"] == len(packets)
        assert dict(parser.rejects) == {"bad_length": 1}
        assert len(readings) == 2  # frames 12072 (partial) and 12073 completed
        assert parser.counts["points"] == 12783 + 58797
        assert receiver.is_alive()
