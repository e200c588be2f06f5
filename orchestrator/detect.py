"""``python main.py detect SCENE --out D``: the car's cone detector on recorded point clouds.

A scene is a folder of point clouds (``points/*.bin`` in the KITTI layout, ``.npy`` or ``.pcd``;
:mod:`sensors.point_cloud_files`), with ``labels/`` when its cones were labelled, or a pcap
capture of a supported LiDAR, decoded a sweep at a time. Each cloud goes through the very
:class:`~sensors.cone_detector.ConeDetector` the car runs, with the settings of the config's
``[sensors.detect]`` section (estimated ground, the car's footprint in the LiDAR frame), and the
sensor model of ``--lidar`` (or the config's).

Writes into the output folder:

- ``detections.csv``: ``frame,x_m,y_m,z_m,size``, one row a cone, in the LiDAR frame (x forward,
  y left, z up; z is the fitted ground under the cone, its base); ``size`` small or large;
- ``summary.json``: frames, points, ``detect_ms_median`` and ``detect_ms_p99`` (wall time of the
  detector per cloud, on one core), what was wrong with the files, and with labels the scores
  (:mod:`sensors.cone_scoring`);
- ``frames/<frame>.png``: a top view of the points, the labels and the detections, with a
  legend; ``report.html``: the figures, a table a frame and a few frames, in one file.
"""

from __future__ import annotations

import argparse
import base64
import csv
import html
import json
import logging
import math
import sys
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from common.car import CarConfig
from common.errors import DecodeError, FsdError
from common.json_values import json_ready
from common.messages import ConeSize
from orchestrator.config import AppConfig
from orchestrator.progress import Progress
from sensors.cone_detector import ConeDetector
from sensors.cone_scoring import FrameScore, ScoreTotals, ScoringWindow, score_frame
from sensors.config import SceneDetectConfig
from sensors.lidar_models import LidarModel, lidar_model
from sensors.point_cloud_files import PointCloudError, Scene, open_scene

log = logging.getLogger(__name__)

FRAMES_IN_REPORT = 6
"""Frames embedded in report.html (all are in frames/)."""
VIEW_RANGE_M = 20.0
"""Half the side of the square a frame's picture shows, around the sensor (m)."""


@dataclass(slots=True)
class Sweep:
    """One cloud to detect in: ``points`` (N, 4) x, y, z (m, LiDAR frame), intensity;
    ``rings`` (N,) or None; ``labels`` (M, 3) or None when the scene has none."""

    frame: str
    points: NDArray[np.float64]
    rings: NDArray[np.int64] | None
    labels: NDArray[np.float64] | None


@dataclass(slots=True)
class FrameResult:
    frame: str
    points: int
    detect_ms: float
    cones_xyz: NDArray[np.float64]
    """(K, 3) in the LiDAR frame (m)."""
    large: NDArray[np.bool_]
    score: FrameScore | None


def choose_model(args_lidar: str | None, config: AppConfig) -> LidarModel:
    """``--lidar``, else ``sensors.detect.lidar_model``, else the car's ``sensors.lidar.model``."""
    name = (args_lidar or config.sensors.detect.lidar_model
            or str(getattr(config.sensors.lidar, "model", "vlp16")))
    try:
        return lidar_model(name)
    except ValueError as exc:
        raise FsdError(str(exc)) from None


def detection_car(settings: SceneDetectConfig) -> CarConfig:
    """A car whose origin is the sensor, so that the detector's footprint cut and its output
    are in the LiDAR frame."""
    front, rear = settings.footprint_front_m, settings.footprint_rear_m
    return CarConfig(lidar_x_m=0.0, lidar_z_m=settings.mount_height_m, length_m=front + rear,
                     rear_overhang_m=rear, width_m=2.0 * settings.footprint_half_width_m)


def _scene_sweeps(scene: Scene, skipped: list[str], summary: dict[str, Any]
                  ) -> Iterator[Sweep]:
    summary["metadata"] = scene.metadata.as_dict()
    summary["has_labels"] = scene.labels_dir is not None
    for cloud in scene.clouds(skipped):
        points = np.column_stack([cloud.xyz, cloud.intensity])
        yield Sweep(cloud.frame, points, cloud.rings, scene.labels(cloud.frame))


def _pcap_sweeps(source: Path, model: LidarModel, meta: str | None,
                 summary: dict[str, Any]) -> Iterator[Sweep]:
    from sensors.decode_lidar import iter_pcap_sweeps

    summary["has_labels"] = False
    for index, (points, rings, _times, _end) in enumerate(
            iter_pcap_sweeps(source, model.name, meta)):
        yield Sweep(f"{index:07d}", np.asarray(points, dtype=np.float64), rings, None)


def run_detect(args: argparse.Namespace, config: AppConfig) -> dict[str, Any]:
    """The ``detect`` command's work; returns the summary (as written to summary.json)."""
    source = Path(args.scene)
    out = Path(args.out)
    model = choose_model(args.lidar, config)
    settings = config.sensors.detect
    car = detection_car(settings)
    try:
        detector = ConeDetector(settings.detector, car, model)
    except ValueError as exc:
        raise FsdError(str(exc)) from None
    window = ScoringWindow()
    summary: dict[str, Any] = {"source": str(source), "lidar_model": model.name}
    skipped: list[str] = []
    total: int | None = None
    if source.is_file() and source.suffix.lower() in (".pcap", ".cap"):
        sweeps = _pcap_sweeps(source, model, args.meta, summary)
    elif source.is_dir():
        try:
            scene = open_scene(source)
        except PointCloudError as exc:
            raise FsdError(str(exc)) from None
        total = len(scene.cloud_files)
        sweeps = _scene_sweeps(scene, skipped, summary)
    else:
        raise FsdError(f"{source}: not a scene folder (points/*.bin, .npy, .pcd) or a .pcap "
                       "capture")
    try:
        first = next(sweeps)
    except (PointCloudError, DecodeError) as exc:
        raise FsdError(str(exc)) from None
    except StopIteration:
        raise FsdError(f"{source}: no readable point cloud in it") from None

    out.mkdir(parents=True, exist_ok=True)
    frames_dir = out / "frames"
    if args.frames != 0:  # None: every frame
        frames_dir.mkdir(exist_ok=True)
    # one detection before timing: the first call imports scipy's k-d tree and warms caches
    detector.detect(first.points, first.rings, np.zeros(first.points.shape[0]), 0.0)
    progress = Progress("detect", total, "clouds",
                        bar=sys.stderr.isatty() and not args.json)
    results: list[FrameResult] = []
    totals = ScoreTotals()
    strict = ScoreTotals()
    drawn = 0
    with (out / "detections.csv").open("w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(["frame", "x_m", "y_m", "z_m", "size"])
        for sweep in _chain(first, sweeps):
            result = _detect_one(detector, sweep, window)
            results.append(result)
            for (x, y, z), large in zip(result.cones_xyz, result.large, strict=True):
                writer.writerow([sweep.frame, f"{x:.3f}", f"{y:.3f}", f"{z:.3f}",
                                 "large" if large else "small"])
            if result.score is not None and sweep.labels is not None:
                totals.add(result.score)
                strict.add(score_frame(sweep.labels[:, :2], result.cones_xyz[:, :2], window,
                                       strict=True))
            if args.frames is None or drawn < args.frames:
                _draw_frame(frames_dir / f"{sweep.frame}.png", sweep, result, detector, window)
                drawn += 1
            progress.update(len(results), lambda: f"{len(results)} clouds")
    progress.close()

    times = np.array([r.detect_ms for r in results])
    summary.update({
        "frames": len(results),
        "frames_skipped": len(skipped),
        "skipped_files": skipped,
        "points": int(sum(r.points for r in results)),
        "cones": int(sum(r.cones_xyz.shape[0] for r in results)),
        "detect_ms_median": round(float(np.median(times)), 3),
        "detect_ms_p99": round(float(np.percentile(times, 99)), 3),
    })
    if summary.get("has_labels"):
        summary["scoring"] = {
            "window": {"min_x_m": window.min_x_m, "max_range_m": window.max_range_m,
                       "match_m": window.match_m},
            "edges": "a pair straddling the window's edge counts against neither side",
        }
        summary.update(totals.as_dict())
        summary["strict"] = strict.as_dict()
        summary["frame_offset"] = totals.frame_offset_dict()
    summary = json_ready(summary)
    (out / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    _write_report(out, summary, results)
    return summary


def _chain(first: Sweep, rest: Iterator[Sweep]) -> Iterator[Sweep]:
    yield first
    yield from rest


def _detect_one(detector: ConeDetector, sweep: Sweep, window: ScoringWindow) -> FrameResult:
    points = sweep.points
    times = np.zeros(points.shape[0])
    t0 = time.perf_counter()
    cones = detector.detect(points, sweep.rings, times, 0.0)
    detect_ms = (time.perf_counter() - t0) * 1e3
    xy = np.array([[c.x_m - detector.lidar_x_m, c.y_m] for c in cones.cones]).reshape(-1, 2)
    z = detector.ground.height_m(xy[:, 0], xy[:, 1]) if xy.size else np.zeros(0)
    large = np.array([c.size == ConeSize.LARGE for c in cones.cones], dtype=bool)
    score = (score_frame(sweep.labels[:, :2], xy, window) if sweep.labels is not None
             else None)
    return FrameResult(sweep.frame, int(points.shape[0]), detect_ms, np.c_[xy, z], large, score)


def _draw_frame(path: Path, sweep: Sweep, result: FrameResult, detector: ConeDetector,
                window: ScoringWindow) -> None:
    """A top view of one cloud: points by height above the ground, labels, detections."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    pts = sweep.points
    near = (np.abs(pts[:, 0]) < VIEW_RANGE_M) & (np.abs(pts[:, 1]) < VIEW_RANGE_M)
    height = pts[near, 2] - detector.ground.height_m(pts[near, 0], pts[near, 1])
    fig, ax = plt.subplots(figsize=(7.5, 7.5), dpi=90)
    shown = ax.scatter(pts[near, 1], pts[near, 0], c=np.clip(height, -0.1, 0.8), s=0.6,
                       cmap="viridis", vmin=-0.1, vmax=0.8, label="returns", rasterized=True)
    fig.colorbar(shown, ax=ax, shrink=0.7, label="height above the fitted ground (m)")
    if sweep.labels is not None and sweep.labels.size:
        ax.scatter(sweep.labels[:, 1], sweep.labels[:, 0], s=110, facecolors="none",
                   edgecolors="tab:red", linewidths=1.4, label="labelled cone")
    cones = result.cones_xyz
    if cones.size:
        ax.scatter(cones[~result.large, 1], cones[~result.large, 0], marker="x", s=60,
                   c="black", linewidths=1.6, label="detected cone")
        if result.large.any():
            ax.scatter(cones[result.large, 1], cones[result.large, 0], marker="X", s=90,
                       c="tab:orange", edgecolors="black", label="detected large cone")
    arc = np.linspace(-math.pi / 2, math.pi / 2, 90)
    ax.plot(window.max_range_m * np.sin(arc), window.max_range_m * np.cos(arc), "--",
            color="grey", lw=0.8, label=f"scored: x > {window.min_x_m:g} m, "
            f"range < {window.max_range_m:g} m")
    ax.axhline(window.min_x_m, color="grey", lw=0.8, ls="--")
    title = f"{sweep.frame}: {cones.shape[0]} cones, {result.points} points"
    if result.score is not None:
        s = result.score
        title += f"  (hits {s.true_positives}, false {s.false_positives}, missed {s.misses})"
    ax.set_title(title, fontsize=10)
    ax.set_xlabel("y (m, left is +)")
    ax.set_ylabel("x (m, ahead)")
    ax.set_xlim(VIEW_RANGE_M, -VIEW_RANGE_M)  # left of the car on the left of the picture
    ax.set_ylim(-5.0, 2 * VIEW_RANGE_M - 5.0)
    ax.set_aspect("equal")
    ax.legend(loc="lower left", fontsize=8, framealpha=0.9)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


HEADLINE = ("source", "lidar_model", "frames", "frames_skipped", "points", "cones",
             "detect_ms_median", "detect_ms_p99", "recall", "precision",
             "median_position_error_m", "true_positives", "false_positives", "misses")


def _write_report(out: Path, summary: dict[str, Any], results: list[FrameResult]) -> None:
    e = html.escape
    parts = ["<!doctype html><html><head><meta charset='utf-8'><title>detect: "
             f"{e(str(summary['source']))}</title><style>body{{font-family:sans-serif;"
             "margin:2em}table{border-collapse:collapse}td,th{border:1px solid #ccc;"
             "padding:2px 8px;text-align:right}td.k{text-align:left}img{margin:4px}</style>"
             f"</head><body><h1>Cone detection: {e(str(summary['source']))}</h1><table>"]
    for key in HEADLINE:
        if key in summary:
            parts.append(f"<tr><td class='k'>{e(key)}</td><td>{e(str(summary[key]))}</td></tr>")
    parts.append("</table>")
    frames = sorted((out / "frames").glob("*.png")) if (out / "frames").is_dir() else []
    if frames:
        step = max(1, len(frames) // FRAMES_IN_REPORT)
        parts.append(f"<h2>Frames</h2><p>{len(frames)} in <a href='frames/'>frames/</a>.</p>")
        for path in frames[::step][:FRAMES_IN_REPORT]:
            uri = base64.b64encode(path.read_bytes()).decode("ascii")
            parts.append(f"<a href='frames/{e(path.name)}'><img width='480' "
                         f"src='data:image/png;base64,{uri}' alt='{e(path.name)}'></a>")
    parts.append("<h2>Each frame</h2><table><tr><th>frame</th><th>points</th><th>cones</th>"
                 "<th>hits</th><th>false</th><th>missed</th><th>ms</th></tr>")
    for r in results:
        s = r.score
        cells = [r.frame, str(r.points), str(r.cones_xyz.shape[0]),
                 *(("", "", "") if s is None else
                   (str(s.true_positives), str(s.false_positives), str(s.misses))),
                 f"{r.detect_ms:.2f}"]
        parts.append("<tr>" + "".join(f"<td>{e(c)}</td>" for c in cells) + "</tr>")
    parts.append("</table><h2>summary.json</h2><pre>"
                 f"{e(json.dumps(summary, indent=2))}</pre></body></html>\n")
    (out / "report.html").write_text("".join(parts), encoding="utf-8")
