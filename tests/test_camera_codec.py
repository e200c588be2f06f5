"""Camera protobuf datagrams: round trip, rejects, and the simulated camera."""

from __future__ import annotations

import math
import socket
from types import SimpleNamespace

import numpy as np
import pytest

from common.errors import DecodeError
from common.messages import CameraCones, ConeColour, ConeDetection, GroundTruth
from orchestrator.config import AppConfig
from sensors import camera_pb2
from sensors.camera_codec import CameraParser, decode_camera_cones, encode_camera_cones
from simulator.camera_model import CameraModel


def _frame() -> CameraCones:
    return CameraCones(
        timestamp_s=12.345678,
        cones=(ConeDetection(12.345678, 3.5, -1.25, ConeColour.YELLOW, confidence=0.75),
               ConeDetection(12.345678, 8.0, 2.0, ConeColour.BIG_ORANGE, confidence=0.5)),
        frame_id=42,
    )


def test_round_trip() -> None:
    cc = decode_camera_cones(encode_camera_cones(_frame()))
    assert cc.timestamp_s == 12.345678 and cc.frame_id == 42
    assert [c.colour for c in cc.cones] == [ConeColour.YELLOW, ConeColour.BIG_ORANGE]
    assert cc.cones[0].x_m == pytest.approx(3.5) and cc.cones[0].y_m == pytest.approx(-1.25)
    assert cc.cones[0].confidence == pytest.approx(0.75)
    assert all(c.timestamp_s == 12.345678 for c in cc.cones)
    empty = CameraCones(1.0, (), 1)
    assert decode_camera_cones(encode_camera_cones(empty)).cones == ()


def test_generated_module_matches_proto() -> None:
    fields = [f.name for f in camera_pb2.CameraCones.DESCRIPTOR.fields]
    assert fields == ["timestamp_s", "frame_id", "cones"]
    assert [v.name for v in camera_pb2.Colour.DESCRIPTOR.values] == [c.name for c in ConeColour]


def test_over_udp_loopback() -> None:
    rx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    tx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        rx.bind(("127.0.0.1", 0))
        rx.settimeout(2.0)
        tx.sendto(encode_camera_cones(_frame()), rx.getsockname())
        data, _ = rx.recvfrom(65535)
    finally:
        rx.close()
        tx.close()
    parser = CameraParser()
    out = parser.feed(0.0, data)
    assert len(out) == 1 and len(out[0].cones) == 2


def test_bad_datagrams_are_counted() -> None:
    parser = CameraParser()
    good = encode_camera_cones(_frame())
    bad = [b"", good[:-3], b"\xff" * 20, b"$GPGGA,not,a,camera*00\r\n"]
    nan = camera_pb2.CameraCones(timestamp_s=1.0)
    nan.cones.add(x_m=math.nan, y_m=0.0)
    bad.append(nan.SerializeToString())
    conf = camera_pb2.CameraCones(timestamp_s=1.0)
    conf.cones.add(x_m=1.0, y_m=0.0, confidence=3.0)
    bad.append(conf.SerializeToString())
    colour = camera_pb2.CameraCones(timestamp_s=1.0)
    colour.cones.add(x_m=1.0, y_m=0.0, colour=9)  # type: ignore[arg-type]
    bad.append(colour.SerializeToString())
    for payload in bad:
        assert parser.feed(0.0, payload) == []
    assert sum(parser.rejects.values()) == len(bad)
    with pytest.raises(DecodeError):
        decode_camera_cones(b"\xff" * 20)
    rng = np.random.default_rng(0)
    for _ in range(300):  # random bytes never raise
        parser.feed(0.0, rng.integers(0, 256, int(rng.integers(1, 80)), dtype=np.uint8).tobytes())


def _track() -> SimpleNamespace:
    xs = np.arange(2.0, 40.0, 4.0)
    cones = np.r_[np.c_[xs, np.full_like(xs, 1.75)], np.c_[xs, np.full_like(xs, -1.75)]]
    colours = np.r_[np.full(len(xs), int(ConeColour.BLUE)),
                    np.full(len(xs), int(ConeColour.YELLOW))]
    return SimpleNamespace(cones_xy_m=cones, colours=colours, sizes=np.ones(len(cones), int))


def test_camera_model_rate_latency_fov_and_noise() -> None:
    config = AppConfig()
    model = CameraModel(config, np.random.default_rng(4))
    track = _track()
    parser = CameraParser()
    raws = []
    for i in range(1, 401):  # 2 s, static car at the origin
        t = i * 0.005
        raws.extend(model.poll(t, GroundTruth(t, 0, 0, 0, 0, 0, 0), None, track))
    cfg = config.sim.camera
    assert abs(len(raws) - 2.0 * cfg.rate_hz) <= 2
    frames = [f for r in raws for f in parser.feed(r.timestamp_s, r.payload)]
    for r, f in zip(raws, frames, strict=True):
        assert r.timestamp_s == pytest.approx(f.timestamp_s + cfg.latency_s)
    errors, colours_ok, n_true = [], [], 0
    for f in frames:
        for c in f.cones:
            d = np.hypot(track.cones_xy_m[:, 0] - c.x_m, track.cones_xy_m[:, 1] - c.y_m)
            j = int(np.argmin(d))
            if d[j] < 1.0:
                n_true += 1
                errors.append(d[j])
                colours_ok.append(int(c.colour) == int(track.colours[j]))
                bearing = math.atan2(c.y_m, c.x_m - config.car.camera_x_m)
                assert abs(bearing) < 0.5 * cfg.fov_rad + 0.1
                assert math.hypot(c.x_m - config.car.camera_x_m, c.y_m) < cfg.max_range_m + 1
    assert n_true > 6 * len(frames)  # 8 cones in view, a few missed
    assert 0.05 < np.median(errors) < 0.5
    assert np.mean(colours_ok) > 0.9


def test_camera_model_exact_without_noise_and_dead() -> None:
    config = AppConfig()
    model = CameraModel(config, np.random.default_rng(4))
    model.noise = False
    track = _track()
    raws = model.poll(0.2, GroundTruth(0.2, 0, 0, 0, 0, 0, 0), None, track)
    frames = [decode_camera_cones(r.payload) for r in raws]
    assert frames
    for f in frames:
        for c in f.cones:
            d = np.hypot(track.cones_xy_m[:, 0] - c.x_m, track.cones_xy_m[:, 1] - c.y_m)
            assert d.min() < 1e-5
    model.dead = True
    assert model.poll(1.0, GroundTruth(1.0, 0, 0, 0, 0, 0, 0), None, track) == []


def test_camera_clock_skew_is_restamped_not_lost() -> None:
    """A camera computer whose clock is 5 s off: its frames are restamped on arrival less the
    assumed latency (counted), so their colour votes are not dropped as stale; a synchronised
    frame keeps its image time; a configured offset is applied."""
    frame = _frame()
    payload = encode_camera_cones(frame)
    parser = CameraParser()
    (same,) = parser.feed(frame.timestamp_s + 0.06, payload)
    assert same.timestamp_s == frame.timestamp_s and parser.counts["restamped"] == 0
    for skew in (5.0, -5.0):
        (late,) = parser.feed(frame.timestamp_s + skew, payload)
        expected = frame.timestamp_s + skew - AppConfig().sensors.camera.assumed_latency_s
        assert late.timestamp_s == pytest.approx(expected)
        assert all(c.timestamp_s == pytest.approx(expected) for c in late.cones)
        assert [(c.x_m, c.colour) for c in late.cones] == [(c.x_m, c.colour) for c in same.cones]
        assert parser.last_skew_s == pytest.approx(skew)
    assert parser.counts["restamped"] == 2
    config = AppConfig()
    config.sensors.camera.clock_offset_s = 5.0
    shifted = CameraParser(config.sensors.camera)
    (on_ours,) = shifted.feed(frame.timestamp_s + 5.05, payload)
    assert on_ours.timestamp_s == pytest.approx(frame.timestamp_s + 5.0)
    assert shifted.counts["restamped"] == 0
