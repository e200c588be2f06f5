"""LiDAR cone detection on simulated sweeps (default noise): recall, false cones, position, size.

The car drives round a circular track (cones 4 m apart on both sides, 3.5 m wide, big orange
cones at the start) at constant speed, so the truth at any time is known exactly; each
detection is compared with the true cones in the vehicle frame at the time it was stamped with.
"""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from common.messages import ConeSize, GroundTruth, LidarCones
from orchestrator.config import AppConfig
from sensors.cone_detector import ConeDetector
from sensors.lidar_parser import LidarParser
from simulator.lidar_model import LidarModel

RADIUS_M = 15.0


def _circle_track() -> SimpleNamespace:
    """Cones on both sides of a circle of radius 15 m centred at (0, 15): the car starts at
    the origin heading +x and turns left."""
    cones, sizes = [], []
    for r in (RADIUS_M - 1.75, RADIUS_M + 1.75):
        n = int(round(2 * math.pi * r / 4.0))
        for i in range(n):
            a = 2 * math.pi * i / n - math.pi / 2
            cones.append((r * math.cos(a), RADIUS_M + r * math.sin(a)))
            sizes.append(int(ConeSize.LARGE) if i in (0, n - 1) else int(ConeSize.SMALL))
    return SimpleNamespace(cones_xy_m=np.array(cones), sizes=np.array(sizes))


def _truth(t_s: float, speed_mps: float) -> GroundTruth:
    rate = speed_mps / RADIUS_M
    yaw = rate * t_s
    return GroundTruth(t_s, RADIUS_M * math.sin(yaw), RADIUS_M * (1 - math.cos(yaw)), yaw,
                       speed_mps, 0.0, rate)


def _simulate(duration_s: float, speed_mps: float, seed: int = 7
              ) -> tuple[AppConfig, SimpleNamespace, list[LidarCones], LidarParser]:
    config = AppConfig()
    track = _circle_track()
    model = LidarModel(config, np.random.default_rng(seed))
    parser = LidarParser(config.sensors.lidar, config.car)
    sweeps: list[LidarCones] = []
    sweep_points = []
    for i in range(1, int(round(duration_s / 0.005)) + 1):
        t = i * 0.005
        for raw in model.poll(t, _truth(t, speed_mps), None, track):
            for cones in parser.feed(raw.timestamp_s, raw.payload):
                sweeps.append(cones)
                sweep_points.append(parser.last_sweep)
    parser.sweep_points = sweep_points  # type: ignore[attr-defined]
    return config, track, sweeps[1:], parser  # the first sweep is partial


def _vehicle_frame(track: SimpleNamespace, t_s: float, speed: float) -> np.ndarray:
    tr = _truth(t_s, speed)
    c, s = math.cos(tr.yaw_rad), math.sin(tr.yaw_rad)
    d = track.cones_xy_m - [tr.x_m, tr.y_m]
    return np.c_[d[:, 0] * c + d[:, 1] * s, -d[:, 0] * s + d[:, 1] * c]


def _evaluate(config: AppConfig, track: SimpleNamespace, sweeps: list[LidarCones],
              parser: LidarParser, speed: float) -> dict[str, float]:
    lx = config.car.lidar_x_m
    found = visible = in_range = found_any = false = 0
    errors, size_ok = [], []
    points = parser.sweep_points[1:]  # type: ignore[attr-defined]
    for sweep, pts in zip(sweeps, points, strict=True):
        mid = 0.5 * (sweep.sweep_start_s + sweep.timestamp_s)
        truth_v = _vehicle_frame(track, mid, speed)
        rel = truth_v - [lx, 0.0]
        rng = np.hypot(rel[:, 0], rel[:, 1])
        fov = np.abs(np.degrees(np.arctan2(rel[:, 1], rel[:, 0]))) < 110.0
        target = (rng < 10.0) & (rng > 1.5) & fov
        # cones the LiDAR actually hit at least 3 times above the ground in this sweep
        p = pts.points
        above = p[:, 2] + config.car.lidar_z_m > 0.05
        hits = np.zeros(len(rel), dtype=int)
        for i in np.flatnonzero(target):
            hits[i] = int(np.sum(above & (np.hypot(p[:, 0] - rel[i, 0], p[:, 1] - rel[i, 1])
                                          < 0.25)))
        seen = np.zeros(len(rel), dtype=bool)
        for cone in sweep.cones:
            tv = _vehicle_frame(track, cone.timestamp_s, speed)
            d = np.hypot(tv[:, 0] - cone.x_m, tv[:, 1] - cone.y_m)
            j = int(np.argmin(d))
            if d[j] > 0.5:
                false += 1
                continue
            seen[j] = True
            errors.append(d[j])
            size_ok.append(int(cone.size) == int(track.sizes[j]))
        in_range += int(target.sum())
        found_any += int((seen & target).sum())
        visible += int((target & (hits >= 3)).sum())
        found += int((seen & target & (hits >= 3)).sum())
    return {
        "recall_visible": found / max(visible, 1),
        "recall_all": found_any / max(in_range, 1),
        "false_per_sweep": false / max(len(sweeps), 1),
        "median_error_m": float(np.median(errors)),
        "size_ok": float(np.mean(size_ok)),
        "sweeps": len(sweeps),
    }


@pytest.fixture(scope="module")
def circle_run() -> dict[str, float]:
    speed = 8.0
    config, track, sweeps, parser = _simulate(2.0, speed)
    return _evaluate(config, track, sweeps, parser, speed)


def test_recall_within_10_m(circle_run: dict[str, float]) -> None:
    assert circle_run["sweeps"] >= 18
    assert circle_run["recall_visible"] >= 0.95, circle_run
    assert circle_run["recall_all"] >= 0.90, circle_run


def test_at_most_one_false_cone_per_sweep(circle_run: dict[str, float]) -> None:
    assert circle_run["false_per_sweep"] <= 1.0, circle_run


def test_median_position_error(circle_run: dict[str, float]) -> None:
    assert circle_run["median_error_m"] <= 0.05, circle_run


def test_small_and_large_told_apart(circle_run: dict[str, float]) -> None:
    assert circle_run["size_ok"] >= 0.95, circle_run


def test_size_classes_at_each_range() -> None:
    """A lone cone of each size straight ahead at 2..10 m, static car, many sweeps."""
    config = AppConfig()
    for size in (ConeSize.SMALL, ConeSize.LARGE):
        for dist in (2.0, 4.0, 6.0, 8.0, 10.0):
            track = SimpleNamespace(
                cones_xy_m=np.array([[config.car.lidar_x_m + dist, 0.4]]),
                sizes=np.array([int(size)]))
            model = LidarModel(config, np.random.default_rng(11))
            parser = LidarParser(config.sensors.lidar, config.car)
            out = []
            for i in range(1, 81):
                t = i * 0.005
                for raw in model.poll(t, GroundTruth(t, 0, 0, 0, 0, 0, 0), None, track):
                    out.extend(parser.feed(raw.timestamp_s, raw.payload))
            cones = [c for sweep in out[1:] for c in sweep.cones]
            assert len(cones) >= 2, (size, dist)
            assert all(c.size == size for c in cones), (size, dist, cones)
            for c in cones:
                assert math.hypot(c.x_m - config.car.lidar_x_m - dist, c.y_m - 0.4) < 0.08


def test_tall_object_and_wall_are_not_cones() -> None:
    """A post (taller than a large cone) and a long wall of points are rejected."""
    config = AppConfig()
    det = ConeDetector(config.sensors.lidar.detector, config.car)
    pts, rings = [], []
    elev = np.radians(np.arange(-15, 16, 2.0))
    az = np.radians(np.arange(-30, 30, 0.2))
    for ring, e in enumerate(elev):
        # a post of radius 0.1 m at 5 m ahead, 1.5 m tall
        for a in az:
            x, y = 5.0 * math.cos(a), 5.0 * math.sin(a)
            if abs(y) < 0.1:
                r = 5.0 / math.cos(e)
                z = r * math.sin(e)
                if -0.3 < z < 1.2:
                    pts.append((x, y, z, 50.0))
                    rings.append(ring)
        # a wall along y = 4 m
        for a in np.radians(np.arange(40, 80, 0.2)):
            d = 4.0 / math.sin(a)
            z = d * math.tan(e)
            if -0.3 < z < 1.0:
                pts.append((d * math.cos(a), 4.0, z, 30.0))
                rings.append(ring)
    p = np.array(pts)
    out = det.detect(p, np.array(rings), np.zeros(len(p)), 0.1)
    assert out.cones == ()


def test_decoding_window_changes_no_cone() -> None:
    """Decoding only the returns inside the detector's window (no ground, not the car's own
    body) gives exactly the cones of decoding them all, and the same point count."""
    config = AppConfig()
    track = _circle_track()
    model = LidarModel(config, np.random.default_rng(3))
    windowed = LidarParser(config.sensors.lidar, config.car)
    everything = LidarParser(config.sensors.lidar, config.car, all_points=True)
    got: list[tuple[LidarCones, LidarCones]] = []
    kept, total = 0, 0
    for i in range(1, int(round(1.5 / 0.005)) + 1):
        t = i * 0.005
        for raw in model.poll(t, _truth(t, 8.0), None, track):
            a = windowed.feed(raw.timestamp_s, raw.payload)
            b = everything.feed(raw.timestamp_s, raw.payload)
            assert len(a) == len(b)
            got.extend(zip(a, b, strict=True))
            if a:
                assert windowed.last_sweep is not None and everything.last_sweep is not None
                kept += windowed.last_sweep.points.shape[0]
                total += everything.last_sweep.points.shape[0]
    assert len(got) >= 12
    assert sum(len(a.cones) for a, _ in got) > 50
    for a, b in got:
        assert a.cones == b.cones
        assert a.timestamp_s == b.timestamp_s and a.point_count == b.point_count
        assert a.sweep_start_s == b.sweep_start_s
    assert kept < 0.6 * total  # the ground and the car's body are most of a sweep


def test_sweep_with_nothing_in_the_window_still_reported() -> None:
    """With no cone in view every return is ground or the car itself: the sweeps are still
    reported (10 Hz, no cones), so the LiDAR does not look dead to the health check."""
    config = AppConfig()
    empty = SimpleNamespace(cones_xy_m=np.zeros((0, 2)), sizes=np.zeros(0, np.int64))
    model = LidarModel(config, np.random.default_rng(4))
    parser = LidarParser(config.sensors.lidar, config.car)
    sweeps: list[LidarCones] = []
    for i in range(1, int(round(1.0 / 0.005)) + 1):
        t = i * 0.005
        for raw in model.poll(t, _truth(t, 8.0), None, empty):
            sweeps.extend(parser.feed(raw.timestamp_s, raw.payload))
    assert 9 <= len(sweeps) <= 11
    assert all(not s.cones and s.point_count > 1000 for s in sweeps)
    last = parser.last_sweep
    assert last is not None and last.points.shape[0] < 0.25 * last.return_count


def _static_cones(cones_xy_m: np.ndarray, sweeps: int = 4) -> list[LidarCones]:
    """Sweeps of a standing car (at the origin, heading +x) seeing small cones at
    ``cones_xy_m`` (N, 2), world = vehicle frame; the first, partial sweep dropped."""
    config = AppConfig()
    track = SimpleNamespace(cones_xy_m=cones_xy_m,
                            sizes=np.full(len(cones_xy_m), int(ConeSize.SMALL)))
    model = LidarModel(config, np.random.default_rng(5))
    parser = LidarParser(config.sensors.lidar, config.car)
    out: list[LidarCones] = []
    for i in range(1, int(round((sweeps + 1) * 0.1 / 0.005)) + 1):
        t = i * 0.005
        for raw in model.poll(t, GroundTruth(t, 0, 0, 0, 0, 0, 0), None, track):
            out.extend(parser.feed(raw.timestamp_s, raw.payload))
    return out[1:]


def test_cones_close_along_a_tight_boundary_are_kept() -> None:
    """Round the tightest hairpins cones stand 0.7 m apart along a boundary (three within the
    cluster radius): every one is still a cone, where the cluster filter would have taken a
    line of them for a bush."""
    angles = np.arange(-0.55, 0.56, 0.7 / 1.7)  # 1.7 m ring, 0.7 m between cones
    ring = np.c_[3.5 + 1.7 * np.sin(angles), 2.2 - 1.7 * np.cos(angles)]
    sweeps = _static_cones(ring)
    assert len(sweeps) >= 3
    for sweep in sweeps:
        got = np.array([(c.x_m, c.y_m) for c in sweep.cones]).reshape(-1, 2)
        assert len(got) == len(ring), (len(got), len(ring))
        nearest = np.min(np.hypot(*(got[:, None, :] - ring[None, :, :]).transpose(2, 0, 1)),
                         axis=0)
        assert np.all(nearest < 0.1)


def test_bush_of_cone_sized_surfaces_is_not_a_cone() -> None:
    """Tall grass beside the track, cone-sized tufts 0.4 m apart (five within 0.9 m of the
    middle one), is removed; a lone cone beside it is kept."""
    bush = np.c_[np.full(7, 6.0), 2.0 + 0.4 * np.arange(7)]
    lone = np.array([[6.0, -3.0]])
    for sweep in _static_cones(np.vstack([bush, lone])):
        got = [(c.x_m, c.y_m) for c in sweep.cones]
        assert len(got) == 1 and math.hypot(got[0][0] - 6.0, got[0][1] + 3.0) < 0.1, got
