"""Simulated VLP-16 packets: decoded by velodyne-decoder, the points lie on the cones and ground."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from common.messages import ConeSize, GroundTruth
from orchestrator.config import AppConfig
from sensors.velodyne import PACKET_DURATION_S, PACKET_SIZE, decode_packets
from simulator.lidar_model import LARGE_CONE, SMALL_CONE, LidarModel


def _track() -> SimpleNamespace:
    """Two rows of cones 3.2 m apart, every fifth one large, plus a few scattered ones."""
    xs = np.arange(2.0, 40.0, 3.0)
    cones = np.r_[np.c_[xs, np.full_like(xs, 1.6)], np.c_[xs + 1.0, np.full_like(xs, -1.6)],
                  [[6.0, 0.3], [-3.0, 4.0], [12.0, 6.0]]]
    sizes = np.full(len(cones), int(ConeSize.SMALL))
    sizes[::5] = int(ConeSize.LARGE)
    return SimpleNamespace(cones_xy_m=cones, sizes=sizes)


def _truth(t_s: float, speed_mps: float, yaw_rate_radps: float) -> GroundTruth:
    """A car on a constant-speed arc (or line) from the origin along +x."""
    if abs(yaw_rate_radps) < 1e-9:
        return GroundTruth(t_s, speed_mps * t_s, 0.0, 0.0, speed_mps, 0.0, 0.0)
    yaw = yaw_rate_radps * t_s
    radius = speed_mps / yaw_rate_radps
    return GroundTruth(t_s, radius * math.sin(yaw), radius * (1.0 - math.cos(yaw)), yaw,
                       speed_mps, 0.0, yaw_rate_radps)


def _run(model: LidarModel, track: SimpleNamespace, duration_s: float, speed_mps: float = 0.0,
         yaw_rate_radps: float = 0.0, dt_s: float = 0.005) -> list:
    raws = []
    for i in range(1, int(round(duration_s / dt_s)) + 1):
        t = i * dt_s
        raws.extend(model.poll(t, _truth(t, speed_mps, yaw_rate_radps), None, track))
    return raws


def _surface_distance(points_world: np.ndarray, track: SimpleNamespace,
                      sensor_xy: np.ndarray | None = None) -> np.ndarray:
    """Distance (m) of each world point (x, y, z above ground) to the nearest surface; with
    ``sensor_xy`` (N, 2) only cone surface facing the sensor counts."""
    best = np.abs(points_world[:, 2])  # the ground
    for (cx, cy), size in zip(track.cones_xy_m, track.sizes, strict=True):
        radius, height = LARGE_CONE if size == int(ConeSize.LARGE) else SMALL_CONE
        rho = np.hypot(points_world[:, 0] - cx, points_world[:, 1] - cy)
        z = points_world[:, 2]
        cos_half = height / math.hypot(radius, height)
        surface = radius * (1.0 - np.clip(z, 0.0, height) / height)
        d = np.abs(rho - surface) * cos_half
        d = np.where((z >= -0.01) & (z <= height + 0.01), d, np.inf)
        if sensor_xy is not None:
            # the outward normal (horizontal part) must point towards the sensor, up to grazing
            nx, ny = points_world[:, 0] - cx, points_world[:, 1] - cy
            vx, vy = sensor_xy[:, 0] - points_world[:, 0], sensor_xy[:, 1] - points_world[:, 1]
            cos_facing = (nx * vx + ny * vy) / (np.hypot(nx, ny) * np.hypot(vx, vy) + 1e-12)
            d = np.where(cos_facing > -0.1, d, np.inf)
        best = np.minimum(best, d)
    return best


def _to_world(points: np.ndarray, times: np.ndarray, config: AppConfig, speed: float,
              yaw_rate: float) -> tuple[np.ndarray, np.ndarray]:
    """Sensor-frame points (N, 3) at their times to the world; also the sensor's (N, 2)."""
    out = np.empty((points.shape[0], 3))
    sensor = np.empty((points.shape[0], 2))
    for i in range(points.shape[0]):
        tr = _truth(float(times[i]), speed, yaw_rate)
        c, s = math.cos(tr.yaw_rad), math.sin(tr.yaw_rad)
        x = points[i, 0] + config.car.lidar_x_m
        out[i, 0] = tr.x_m + c * x - s * points[i, 1]
        out[i, 1] = tr.y_m + s * x + c * points[i, 1]
        out[i, 2] = points[i, 2] + config.car.lidar_z_m
        sensor[i] = tr.x_m + c * config.car.lidar_x_m, tr.y_m + s * config.car.lidar_x_m
    return out, sensor


def test_packet_format_and_rate() -> None:
    config = AppConfig()
    model = LidarModel(config, np.random.default_rng(0))
    raws = _run(model, _track(), 1.0)
    # 600 rpm: a packet every 1.327104 ms, about 753.5 per second, 75 per sweep
    assert len(raws) == int(1.0 / PACKET_DURATION_S)
    assert all(len(r.payload) == PACKET_SIZE and r.source == "lidar" for r in raws)
    stamps = np.array([r.timestamp_s for r in raws])
    np.testing.assert_allclose(np.diff(stamps), PACKET_DURATION_S, atol=1e-9)
    dec = decode_packets([r.payload for r in raws[:76]])
    # one sweep of azimuths in ~0.2 deg steps
    az0 = np.sort(np.unique(np.round(dec.azimuth_deg[dec.rings == 0], 2)))
    assert 0.19 < np.median(np.diff(az0)) < 0.21
    assert az0.max() - az0.min() > 359.0


@pytest.mark.parametrize(("speed", "yaw_rate"), [(0.0, 0.0), (12.0, 0.0), (10.0, 0.5)])
def test_points_decoded_by_velodyne_decoder_lie_on_cones_and_ground(speed: float,
                                                                     yaw_rate: float) -> None:
    import velodyne_decoder as vd
    config = AppConfig()
    model = LidarModel(config, np.random.default_rng(1))
    model.noise = False
    track = _track()
    raws = _run(model, track, 0.25, speed, yaw_rate)
    decoder = vd.StreamDecoder(vd.Config(model=vd.Model.VLP16))
    clouds = []
    for r in raws:
        # velodyne-decoder stamps a packet's returns from its first firing
        result = decoder.decode(r.timestamp_s - PACKET_DURATION_S, r.payload)
        if result is not None:
            clouds.append((result[0].host, result[1]))
    result = decoder.finish()
    if result is not None:
        clouds.append((result[0].host, result[1]))
    pts = np.concatenate([c for _, c in clouds]).astype(np.float64)
    times = np.concatenate([stamp + c[:, 4].astype(np.float64) for stamp, c in clouds])
    world, sensor = _to_world(pts[:, :3], times, config, speed, yaw_rate)
    dist = _surface_distance(world, track, sensor)
    cone_hits = pts[:, 3] == 70  # the model's cone reflectivity
    assert cone_hits.sum() > 500
    assert np.all(dist[pts[:, 3] != 40] < 0.03)  # every return but the car body's
    assert np.percentile(dist[cone_hits], 99) < 0.01


def test_occlusion_nearest_cone_wins() -> None:
    config = AppConfig()
    model = LidarModel(config, np.random.default_rng(2))
    model.noise = False
    # a small cone straight ahead at 4 m hides a large one behind it at 8 m on the same bearing
    track = SimpleNamespace(cones_xy_m=np.array([[config.car.lidar_x_m + 4.0, 0.0],
                                                 [config.car.lidar_x_m + 8.0, 0.0]]),
                            sizes=np.array([int(ConeSize.SMALL), int(ConeSize.LARGE)]))
    raws = _run(model, track, 0.11)
    dec = decode_packets([r.payload for r in raws])
    ahead = (np.abs(np.degrees(np.arctan2(dec.points[:, 1], dec.points[:, 0]))) < 0.5)
    r = np.hypot(dec.points[ahead, 0], dec.points[ahead, 1])
    low = dec.points[ahead, 2] + config.car.lidar_z_m < 0.3
    assert np.all(r[low & (dec.points[ahead, 2] > -0.25)] < 4.1)  # cone returns below its top
    # the large cone shows above the small one's top only
    far = r > 7.5
    assert np.all(dec.points[ahead][far, 2] + config.car.lidar_z_m > 0.3)


def test_deterministic_dead_and_loss() -> None:
    config = AppConfig()
    a = _run(LidarModel(config, np.random.default_rng(5)), _track(), 0.2)
    b = _run(LidarModel(config, np.random.default_rng(5)), _track(), 0.2)
    assert [r.payload for r in a] == [r.payload for r in b]
    model = LidarModel(config, np.random.default_rng(5))
    model.dead = True
    assert _run(model, _track(), 0.2) == []
    config.sim.lidar.packet_loss_prob = 0.5
    lossy = _run(LidarModel(config, np.random.default_rng(5)), _track(), 1.0)
    assert 250 < len(lossy) < 500


def test_range_noise_sigma() -> None:
    config = AppConfig()
    model = LidarModel(config, np.random.default_rng(3))
    raws = _run(model, SimpleNamespace(cones_xy_m=np.zeros((0, 2)), sizes=np.zeros(0)), 0.2)
    dec = decode_packets([r.payload for r in raws])
    ground = (dec.points[:, 3] == 12) & (dec.rings == 0)  # -15 deg laser on the ground
    rng3d = np.linalg.norm(dec.points[ground, :3] - [0, 0, 0.0112], axis=1)
    expected = (config.car.lidar_z_m + 0.0112) / math.sin(math.radians(15.0))
    assert abs(np.std(rng3d) - config.sim.lidar.range_sigma_m) < 0.003
    assert abs(np.mean(rng3d) - expected) < 0.003


def _timed(model: LidarModel, track: SimpleNamespace, duration_s: float, speed_mps: float,
           yaw_rate_radps: float, dead_from_s: float = math.inf) -> list:
    """(poll time, unit) of every unit polled, the sensor dead from ``dead_from_s``."""
    out = []
    for i in range(1, int(round(duration_s / 0.005)) + 1):
        t = i * 0.005
        model.dead = t >= dead_from_s
        out.extend((t, u) for u in model.poll(t, _truth(t, speed_mps, yaw_rate_radps), None,
                                              track))
    return out


@pytest.mark.parametrize("dead_from_s", [math.inf, 0.47])
def test_sweep_units_carry_the_packets_and_close_sweeps_at_the_same_poll(
        dead_from_s: float) -> None:
    """A sweep unit is the packets it holds back to back, the same bytes one unit each would
    carry (noise and all); the parser reads it as those packets and completes each sweep at
    the poll it completes at from single packets, with times equal to well under 1 us."""
    from sensors.lidar_parser import LidarParser
    config = AppConfig()
    track = _track()
    single = _timed(LidarModel(config, np.random.default_rng(7)), track, 0.8, 12.0, 0.4,
                    dead_from_s)
    units = _timed(LidarModel(config, np.random.default_rng(7), sweep_units=True), track, 0.8,
                   12.0, 0.4, dead_from_s)
    assert all(len(u.payload) % PACKET_SIZE == 0 for _, u in units)
    sent = b"".join(u.payload for _, u in single)
    assert b"".join(u.payload for _, u in units) == sent[:sum(len(u.payload) for _, u in units)]
    assert 5 <= len(units) <= 9
    assert units[-1][1].timestamp_s <= min(dead_from_s, 0.8)

    def sweeps(polled: list) -> list:
        parser = LidarParser(config.sensors.lidar, config.car)
        return [(t, c) for t, u in polled for c in parser.feed(u.timestamp_s, u.payload)]

    a, b = sweeps(single), sweeps(units)
    assert len(b) == len(a) >= 4
    for (ta, ca), (tb, cb) in zip(a, b, strict=True):
        assert ta == tb
        assert abs(ca.timestamp_s - cb.timestamp_s) < 1e-6
        assert len(ca.cones) == len(cb.cones)


def test_a_sweep_unit_of_another_model_is_refused_as_its_packets_are() -> None:
    """The checks a sweep unit passes at once are the per-packet ones: packets of another
    Velodyne (here VLP-32C ids) are refused, counted alike, whether they come one by one or
    as units; good units after them are decoded again."""
    from sensors.lidar_parser import LidarParser
    config = AppConfig()
    track = _track()
    single = _timed(LidarModel(config, np.random.default_rng(3)), track, 0.5, 5.0, 0.0)
    units = _timed(LidarModel(config, np.random.default_rng(3), sweep_units=True), track, 0.5,
                   5.0, 0.0)

    def foreign(payload: bytes) -> bytes:
        rows = np.frombuffer(payload, dtype=np.uint8).reshape(-1, PACKET_SIZE).copy()
        rows[:, 1205] = 0x28
        return rows.tobytes()

    def fed(polled: list, bad_until_s: float) -> LidarParser:
        parser = LidarParser(config.sensors.lidar, config.car)
        for _, u in polled:
            payload = foreign(u.payload) if u.timestamp_s <= bad_until_s else u.payload
            parser.feed(u.timestamp_s, payload)
        return parser

    second_s = units[1][1].timestamp_s  # the packets of the first two units are foreign
    a, b = fed(single, second_s), fed(units, second_s)
    assert b.rejects["wrong_model"] > 50
    assert b.refused == a.refused
    assert a.counts["packets"] + a.rejects["wrong_model"] == len(single)
    assert b.counts["packets"] + b.rejects["wrong_model"] == sum(
        len(u.payload) // PACKET_SIZE for _, u in units)
    assert b.counts["sweeps"] >= 1
