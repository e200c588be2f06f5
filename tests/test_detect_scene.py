"""LiDAR scenes (issue 41): the readers, the scoring, the fitted ground and ``detect`` on a real
Formula Student car's Pandar40P clouds with labelled cones."""

from __future__ import annotations

import json
import logging
import math
import shutil
from pathlib import Path

import numpy as np
import pytest

from common.car import CarConfig
from main import cli
from orchestrator.config import load_config
from orchestrator.detect import choose_model, detection_car
from sensors.cone_detector import ConeDetector
from sensors.cone_scoring import ScoreTotals, ScoringWindow, score_frame
from sensors.config import DetectorConfig
from sensors.ground import fit_ground
from sensors.lidar_models import LIDAR_MODELS, lidar_model, rings_from_elevation
from sensors.point_cloud_files import PointCloudError, open_scene, read_cloud, read_labels
from support.shared_data import shared_data

FSKITTI = ("lidar", "fskitti")
ALVERCA = "camera_alverca_autox_april1"
ESTORIL = "camera_estoril_autox2"


# --- scoring on hand-made frames -----------------------------------------------------------

def test_scoring_counts_hits_misses_and_false_positives() -> None:
    labels = np.array([[5.0, 1.0], [6.0, -1.0], [9.0, 2.0], [1.0, 0.0], [20.0, 0.0]])
    dets = np.array([[5.1, 1.0], [6.0, -1.3], [10.0, 5.0], [1.0, 0.1]])
    score = score_frame(labels, dets)
    # (1, 0) and (20, 0) are outside the window; (9, 2) is missed; (10, 5) is false
    assert (score.true_positives, score.misses, score.false_positives) == (2, 1, 1)
    assert sorted(np.round(score.errors_m, 6)) == [0.1, 0.3]


def test_scoring_is_one_to_one_and_gated() -> None:
    labels = np.array([[5.0, 0.0], [5.0, 0.4]])
    dets = np.array([[5.0, 0.2]])
    score = score_frame(labels, dets)
    assert (score.true_positives, score.misses, score.false_positives) == (1, 1, 0)
    far = score_frame(np.array([[5.0, 0.0]]), np.array([[5.0, 0.51]]))
    assert (far.true_positives, far.misses, far.false_positives) == (0, 1, 1)


def test_scoring_prefers_the_assignment_with_the_least_total_distance() -> None:
    # greedy nearest-first would pair d0 with l1 (0.1) and leave l0 unmatched
    labels = np.array([[5.0, 0.0], [5.0, 0.45]])
    dets = np.array([[5.0, 0.35], [5.0, 0.85]])
    score = score_frame(labels, dets)
    assert score.true_positives == 2


def test_a_pair_straddling_the_window_edge_counts_against_neither_side() -> None:
    labels = np.array([[2.45, 1.0]])   # just behind x = 2.5
    dets = np.array([[2.55, 1.0]])     # just ahead of it
    fair = score_frame(labels, dets)
    assert (fair.true_positives, fair.misses, fair.false_positives) == (0, 0, 0)
    strict = score_frame(labels, dets, strict=True)
    assert (strict.true_positives, strict.misses, strict.false_positives) == (0, 0, 1)
    inside = score_frame(np.array([[11.9, 0.0]]), np.array([[12.1, 0.0]]))
    assert (inside.true_positives, inside.misses, inside.false_positives) == (1, 0, 0)


def test_totals_pool_frames() -> None:
    totals = ScoreTotals()
    totals.add(score_frame(np.array([[5.0, 0.0]]), np.array([[5.0, 0.1]])))
    totals.add(score_frame(np.array([[6.0, 0.0]]), np.zeros((0, 2))))
    totals.add(score_frame(np.zeros((0, 2)), np.array([[7.0, 0.0]])))
    assert totals.recall == pytest.approx(0.5)
    assert totals.precision == pytest.approx(0.5)
    assert totals.median_error_m == pytest.approx(0.1)
    assert math.isnan(ScoreTotals().recall)


def test_a_common_label_offset_is_told_from_the_detector_error() -> None:
    """Four cones whose labels are all 0.2 m off in y (odometry at the frame's time), with
    detection noise of 0.02 m: the plain error is the offset's, the leave-one-out error the
    noise's; a frame with fewer than three hits tells nothing of its offset."""
    rng = np.random.default_rng(3)
    truth = np.array([[4.0, 1.5], [4.0, -1.5], [8.0, 1.5], [8.0, -1.5]])
    totals = ScoreTotals()
    for _ in range(20):
        dets = truth + rng.normal(0.0, 0.02, truth.shape)
        totals.add(score_frame(truth + [0.0, 0.2], dets))
    totals.add(score_frame(np.array([[5.0, 0.0]]), np.array([[5.0, 0.3]])))
    offset = totals.frame_offset_dict()
    assert offset["frames"] == 20
    assert offset["median_frame_offset_m"] == pytest.approx(0.2, abs=0.02)
    assert totals.median_error_m == pytest.approx(0.2, abs=0.03)
    # |N(0, 0.02^2 (1 + 1/3) I_2)|: Rayleigh median 0.02 * sqrt(4/3) * 1.177 = 0.027 m
    assert offset["median_position_error_without_frame_offset_m"] == pytest.approx(0.027,
                                                                                    abs=0.008)
    assert math.isnan(ScoreTotals().frame_offset_dict()["median_frame_offset_m"])


def test_window_edges() -> None:
    window = ScoringWindow()
    inside = window.inside(np.array([[2.5, 0.0], [2.51, 0.0], [8.0, 8.9], [8.0, 9.0]]))
    assert inside.tolist() == [False, True, True, False]


# --- sensor table and rings ----------------------------------------------------------------

def test_every_sensor_of_the_issue_is_in_the_table() -> None:
    assert set(LIDAR_MODELS) >= {"vlp16", "vlp32c", "hdl32e", "pandar40p", "os1-64"}
    beams = {name: model.beams for name, model in LIDAR_MODELS.items()}
    assert beams["vlp16"] == 16 and beams["hdl32e"] == 32 and beams["pandar40p"] == 40
    assert lidar_model("Pandar40P").name == "pandar40p"
    with pytest.raises(ValueError, match="vlp16"):
        lidar_model("velodyne")


def test_rings_from_elevation_recover_each_beam() -> None:
    for model in LIDAR_MODELS.values():
        elevation = np.radians(np.asarray(model.beam_elevation_deg))
        range_m = np.linspace(3.0, 30.0, elevation.size)
        xyz = np.c_[range_m * np.cos(elevation), np.zeros(elevation.size),
                    range_m * np.sin(elevation)]
        assert np.array_equal(rings_from_elevation(xyz, model), model.laser_ring), model.name


# --- ground --------------------------------------------------------------------------------

def test_the_ground_is_fitted_to_a_slope_with_objects_on_it() -> None:
    rng = np.random.default_rng(4)
    x = rng.uniform(-15.0, 15.0, 20000)
    y = rng.uniform(-15.0, 15.0, 20000)
    ground = -1.1 + 0.03 * x - 0.02 * y + 0.002 * x * x
    z = ground + rng.normal(0.0, 0.005, x.size)
    # boxes 0.5 m high standing on it, a third of the cells' points lifted
    lifted = (np.floor(x) % 3 == 0) & (np.floor(y) % 3 == 0) & (rng.random(x.size) < 0.5)
    z[lifted] += 0.5
    surface = fit_ground(x, y, z, cell_m=1.0, max_residual_m=0.06, fallback_below_sensor_m=0.3)
    err = surface.height_m(x, y) - ground
    # the lowest of each cell's ~22 returns sits about 2 sigma of the noise below the surface
    assert np.abs(err).max() < 0.03
    assert surface.below_sensor_m == pytest.approx(1.1, abs=0.03)


def test_too_little_ground_falls_back_to_the_configured_height() -> None:
    surface = fit_ground(np.array([1.0]), np.array([1.0]), np.array([-1.0]), 1.0, 0.06, 0.3)
    assert surface.below_sensor_m == pytest.approx(0.3)


def test_estimated_ground_finds_a_cone_on_a_slope() -> None:
    """A synthetic 40-beam sweep over ground rising 5 % ahead, one cone 8 m ahead."""
    model = lidar_model("pandar40p")
    azimuth = np.radians(np.arange(-90.0, 90.0, 0.2))
    elevation = np.radians(model.ring_elevation_deg)
    az, el = np.meshgrid(azimuth, elevation)
    az, el = az.ravel(), el.ravel()
    d = np.c_[np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)]
    # ground z = -1.0 + 0.05 x: where each ray meets it
    t = -1.0 / (d[:, 2] - 0.05 * d[:, 0])
    hit = (t > 0) & (t < 40)
    pts = d[hit] * t[hit, None]
    # the cone: returns on its near half, rings that pass through it
    cone_x, cone_y = 8.0, 0.5
    base = -1.0 + 0.05 * cone_x
    ring_z = np.tan(elevation) * cone_x
    cone_pts = []
    for z in ring_z[(ring_z > base + 0.02) & (ring_z < base + 0.3)]:
        radius = 0.114 * (1 - (z - base) / 0.325)
        for a in np.linspace(-1.2, 1.2, 3):
            cone_pts.append((cone_x - radius * math.cos(a), cone_y + radius * math.sin(a), z))
    cloud = np.vstack([pts, np.array(cone_pts)])
    cloud = cloud[~((np.abs(cloud[:, 1] - cone_y) < 0.2) & (np.abs(cloud[:, 0] - cone_x) < 0.2)
                    & (cloud[:, 2] < base + 0.01))]
    cfg = load_config(None).sensors.detect
    detector = ConeDetector(cfg.detector, detection_car(cfg), model)
    cones = detector.detect(cloud, None, np.zeros(len(cloud)), 0.0).cones
    assert len(cones) == 1
    assert math.hypot(cones[0].x_m - cone_x, cones[0].y_m - cone_y) < 0.12
    flat = ConeDetector(DetectorConfig(ground="flat", min_surface_points=1, min_layers=1,
                                       fov_half_deg=180.0),
                        CarConfig(lidar_x_m=0.0, lidar_z_m=1.0, length_m=3.4,
                                  rear_overhang_m=1.0), model)
    # a flat ground 1 m down sees the rising ground ahead as obstacles, not one cone
    assert len(flat.detect(cloud, None, np.zeros(len(cloud)), 0.0).cones) != 1


def test_an_unknown_ground_model_is_refused() -> None:
    with pytest.raises(ValueError, match="ground"):
        ConeDetector(DetectorConfig(ground="bumpy"), CarConfig())


# --- readers -------------------------------------------------------------------------------

def test_bin_readers_take_4_and_5_columns(tmp_path: Path) -> None:
    pts = np.arange(40, dtype=np.float32).reshape(-1, 4)
    (tmp_path / "a.bin").write_bytes(pts.tobytes())
    cloud = read_cloud(tmp_path / "a.bin")
    assert cloud.xyz.shape == (10, 3) and cloud.intensity[1] == 7.0
    five = np.c_[pts[:8, :4], np.full(8, 1.5e9, np.float32)]
    (tmp_path / "b.bin").write_bytes(five.astype(np.float32).tobytes())
    cloud = read_cloud(tmp_path / "b.bin")
    assert cloud.xyz.shape == (8, 3) and cloud.intensity[0] == 3.0
    np.save(tmp_path / "c.npy", pts[:, :3].astype(np.float64))
    assert read_cloud(tmp_path / "c.npy").xyz.shape == (10, 3)


def test_pcd_files_are_read_with_pypcd4(tmp_path: Path) -> None:
    from pypcd4 import PointCloud

    xyzi = np.c_[np.random.default_rng(1).normal(size=(50, 3)), np.arange(50.0)]
    PointCloud.from_xyzi_points(xyzi.astype(np.float32)).save(tmp_path / "f.pcd")
    cloud = read_cloud(tmp_path / "f.pcd")
    assert np.allclose(cloud.xyz, xyzi[:, :3], atol=1e-6)
    assert np.allclose(cloud.intensity, xyzi[:, 3])


@pytest.mark.parametrize("size", [0, 7, 4 * 7])
def test_a_truncated_or_odd_sized_bin_is_refused_by_name(tmp_path: Path, size: int) -> None:
    path = tmp_path / "0000009.bin"
    path.write_bytes(b"\x01" * size)
    with pytest.raises(PointCloudError, match="0000009.bin"):
        read_cloud(path)


def test_labels_skip_placeholders_and_other_classes(tmp_path: Path) -> None:
    path = tmp_path / "l.txt"
    path.write_text("blue_cone 0 0 0 0 0 0 0 0.3 0.2 0.2 5.0 1.0 -1.0 0\n"
                    "yellow_cone 0 0 0 0 0 0 0 0.3 0.2 0.2 0.0 0.0 -1.0 0\n"
                    "car 0 0 0 0 0 0 0 1 1 1 9.0 9.0 -1.0 0\n"
                    "orange_cone 0 0 0\n")
    assert read_labels(path).tolist() == [[5.0, 1.0, -1.0]]


def test_shared_metadata_flaws_are_counted() -> None:
    alverca = open_scene(shared_data(*FSKITTI, ALVERCA))
    assert alverca.metadata.duplicates == 2 and alverca.metadata.syntax_errors == 0
    assert alverca.metadata.frames == len(alverca.cloud_files) == 35
    estoril = open_scene(shared_data(*FSKITTI, ESTORIL))
    assert estoril.metadata.syntax_errors >= 1
    assert estoril.metadata.frames - estoril.metadata.missing_files == len(estoril.cloud_files)


def _copy_scene(tmp_path: Path, frames: list[str]) -> Path:
    source = shared_data(*FSKITTI, ALVERCA)
    scene = tmp_path / "scene"
    (scene / "points").mkdir(parents=True)
    (scene / "labels").mkdir()
    for frame in frames:
        shutil.copy(source / "points" / f"{frame}.bin", scene / "points")
        shutil.copy(source / "labels" / f"{frame}.txt", scene / "labels")
    shutil.copy(source / "metadata.json", scene)
    return scene


def test_a_broken_copy_is_read_for_what_is_valid(tmp_path: Path,
                                                 caplog: pytest.LogCaptureFixture) -> None:
    scene = _copy_scene(tmp_path, ["0000023", "0000024"])
    text = (scene / "metadata.json").read_text()
    (scene / "metadata.json").write_text(text.replace('"data": [', '"data": [ {,', 1))
    (scene / "points" / "0000025.bin").write_bytes(b"\x00" * 30)  # truncated
    out = tmp_path / "out"
    with caplog.at_level(logging.WARNING):
        assert cli(["detect", str(scene), "--lidar", "pandar40p", "--out", str(out),
                    "--frames", "1"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["frames"] == 2 and summary["frames_skipped"] == 1
    assert summary["skipped_files"] == ["0000025.bin"]
    assert summary["metadata"]["syntax_errors"] >= 1
    assert summary["metadata"]["missing_files"] == 32  # not copied (25 is there, truncated)
    assert [r for r in caplog.records if "0000025.bin" in r.getMessage()]


def test_empty_or_foreign_folders_are_refused_in_one_line(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    empty = tmp_path / "empty"
    empty.mkdir()
    assert cli(["detect", str(empty), "--lidar", "pandar40p", "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "no point cloud files" in err and "empty" in err
    foreign = tmp_path / "photos"
    foreign.mkdir()
    (foreign / "a.jpg").write_bytes(b"\xff\xd8")
    assert cli(["detect", str(foreign), "--out", str(tmp_path / "o")]) == 2
    assert ".jpg" in capsys.readouterr().err
    assert cli(["detect", str(tmp_path / "nowhere"), "--out", str(tmp_path / "o")]) == 2


# --- the real car's clouds -------------------------------------------------------------------

def test_every_labelled_cone_of_a_real_frame_is_found_within_015_m() -> None:
    """Frame 23 of the Alverca run: the car parked at a bend, seven cones within 12 m."""
    path = shared_data(*FSKITTI, ALVERCA, "points", "0000023.bin")
    cloud = read_cloud(path)
    labels = read_labels(path.parent.parent / "labels" / "0000023.txt")
    labels = labels[np.hypot(labels[:, 0], labels[:, 1]) < 12.0]
    assert len(labels) >= 5
    config = load_config(None)
    settings = config.sensors.detect
    detector = ConeDetector(settings.detector, detection_car(settings),
                            choose_model("pandar40p", config))
    points = np.c_[cloud.xyz, cloud.intensity]
    cones = detector.detect(points, None, np.zeros(len(points)), 0.0).cones
    found = np.array([[c.x_m, c.y_m] for c in cones])
    for label in labels[:, :2]:
        assert np.hypot(*(found - label).T).min() < 0.15, label
    # the ground 1.0-1.1 m below the sensor, as the data's README says
    assert 1.0 < detector.ground.below_sensor_m < 1.1


def test_detect_writes_its_outputs(tmp_path: Path) -> None:
    scene = _copy_scene(tmp_path, ["0000023", "0000024", "0000025"])
    out = tmp_path / "out"
    assert cli(["detect", str(scene), "--lidar", "pandar40p", "--out", str(out)]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["frames"] == 3 and summary["lidar_model"] == "pandar40p"
    assert summary["recall"] >= 0.9 and summary["precision"] >= 0.9
    assert summary["median_position_error_m"] < 0.1
    assert summary["detect_ms_median"] > 0
    assert summary["frame_offset"]["frames"] == 3
    assert (summary["frame_offset"]["median_position_error_without_frame_offset_m"]
            < 0.1)
    rows = (out / "detections.csv").read_text().splitlines()
    assert rows[0] == "frame,x_m,y_m,z_m,size"
    assert {r.split(",")[0] for r in rows[1:]} == {"0000023", "0000024", "0000025"}
    assert all(r.split(",")[4] in ("small", "large") for r in rows[1:])
    assert sorted(p.name for p in (out / "frames").iterdir()) == [
        "0000023.png", "0000024.png", "0000025.png"]
    assert "0000024" in (out / "report.html").read_text()


def _real_frame_detector() -> tuple[ConeDetector, np.ndarray]:
    path = shared_data(*FSKITTI, ALVERCA, "points", "0000023.bin")
    cloud = read_cloud(path)
    config = load_config(None)
    settings = config.sensors.detect
    detector = ConeDetector(settings.detector, detection_car(settings),
                            choose_model("pandar40p", config))
    return detector, np.c_[cloud.xyz, cloud.intensity]


def _column(x: float, y: float, bottom_m: float, top_m: float, ground_z: float,
            radius_m: float = 0.07, step_m: float = 0.03) -> np.ndarray:
    """Returns on the near side of a vertical column (a leg, a pole) or a floating blob."""
    heights = np.arange(bottom_m, top_m, step_m)
    bearing = math.atan2(y, x)
    rows = []
    for h in heights:
        for a in (-0.6, 0.0, 0.6):
            rows.append((x - radius_m * math.cos(bearing + a), y - radius_m * math.sin(bearing + a),
                         ground_z + h, 10.0))
    return np.array(rows)


def test_legs_poles_and_floating_returns_are_not_cones() -> None:
    """Added to a real frame on open ground ahead: a leg (0-0.9 m), a pole (0-1.6 m) and
    raindrop-like blobs floating 0.3-0.45 m up give no new cone; the real cones stay."""
    detector, points = _real_frame_detector()
    zeros = np.zeros(len(points))
    before = np.array([[c.x_m, c.y_m] for c in detector.detect(points, None, zeros, 0.0).cones])
    ground_z = -detector.ground.below_sensor_m
    spots = [(6.0, -3.0), (7.5, -4.5), (9.0, -5.5), (10.0, -3.0)]
    for spot in spots:
        assert np.hypot(*(before - spot).T).min() > 1.5  # open ground, no cone there
    extra = np.vstack([_column(*spots[0], 0.02, 0.9, ground_z),
                       _column(*spots[1], 0.02, 1.6, ground_z, radius_m=0.05),
                       _column(*spots[2], 0.30, 0.45, ground_z, step_m=0.07),
                       _column(*spots[3], 0.30, 0.45, ground_z, step_m=0.07)])
    cloud = np.vstack([points, extra])
    after = np.array([[c.x_m, c.y_m]
                      for c in detector.detect(cloud, None, np.zeros(len(cloud)), 0.0).cones])
    assert len(after) == len(before)
    assert np.hypot(*(after[:, None, :] - before[None, :, :]).transpose(2, 0, 1)).min(
        axis=1).max() < 0.05
