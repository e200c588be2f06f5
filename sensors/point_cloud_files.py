"""Point clouds saved to files, and folders of them with labelled cones (a "scene").

Formats of one cloud, told by the file's suffix:

- ``.bin``: the KITTI layout, float32 rows of 4 columns (x, y, z in m, intensity) or of 5
  (and a time stamp). A size that is not a whole number of rows of either width is refused.
- ``.npy``: an (N, >=3) array, x y z [intensity [...]].
- ``.pcd``: PCL's point cloud files (ASCII or binary), read with pypcd4; fields ``x y z``, and
  ``intensity`` and ``ring`` where present.

A scene folder holds ``points/`` with one file a frame (frame = the file's stem), optionally
``labels/`` with a KITTI label file per frame (columns 12-14 the cone's x, y, z in the LiDAR
frame; a label at the origin is no cone) and ``metadata.json``, which is only reported on: its
valid frame entries are counted, with duplicates, JSON syntax errors and entries whose point
file is missing; a broken metadata file never stops the scene from being read.
"""

from __future__ import annotations

import json
import logging
import re
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from common.errors import FsdError

log = logging.getLogger(__name__)

CLOUD_SUFFIXES = (".bin", ".npy", ".pcd")
CONE_CLASSES = ("blue_cone", "yellow_cone", "orange_cone", "large_orange_cone", "unknown_cone")


class PointCloudError(FsdError):
    """A point cloud file or scene folder that cannot be read."""


@dataclass(slots=True)
class Cloud:
    """One frame's points in the LiDAR frame.

    ``xyz`` (N, 3) float64 in m; ``intensity`` (N,) float64 (0 where the file has none);
    ``rings`` (N,) int64 when the file carries ring numbers (0 = lowest beam), else None.
    """

    frame: str
    xyz: NDArray[np.float64]
    intensity: NDArray[np.float64]
    rings: NDArray[np.int64] | None = None


def read_cloud(path: str | Path) -> Cloud:
    """One point cloud file; raises :class:`PointCloudError` naming the file and the fault."""
    path = Path(path)
    suffix = path.suffix.lower()
    try:
        if suffix == ".bin":
            return _read_bin(path)
        if suffix == ".npy":
            array = np.load(path, allow_pickle=False)
            return _from_columns(path.stem, np.asarray(array, dtype=np.float64), path)
        if suffix == ".pcd":
            return _read_pcd(path)
    except PointCloudError:
        raise
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise PointCloudError(f"{path}: unreadable {suffix} point cloud ({exc})") from exc
    raise PointCloudError(f"{path}: not a point cloud file (expected one of "
                          f"{', '.join(CLOUD_SUFFIXES)})")


def _read_bin(path: Path) -> Cloud:
    raw = path.read_bytes()
    if len(raw) == 0 or len(raw) % 4:
        raise PointCloudError(f"{path}: {len(raw)} bytes is not a whole number of float32 values")
    values = np.frombuffer(raw, dtype="<f4")
    widths = [w for w in (5, 4) if values.size % w == 0]
    if not widths:
        raise PointCloudError(f"{path}: {values.size} float32 values are not rows of 4 or 5 "
                              "columns (a truncated file?)")
    # a size divisible by both (20 values, 40, ...) reads as 5 columns when the 5th column looks
    # like time stamps (far above any intensity), else as 4
    width = widths[0]
    if len(widths) == 2:
        fifth = values.reshape(-1, 5)[:, 4]
        width = 5 if np.all(np.abs(fifth) > 255.0) else 4
    return _from_columns(path.stem, values.reshape(-1, width).astype(np.float64), path)


def _from_columns(frame: str, array: NDArray[np.float64], path: Path) -> Cloud:
    if array.ndim != 2 or array.shape[1] < 3:
        raise PointCloudError(f"{path}: expected an (N, >=3) array, got shape {array.shape}")
    finite = np.isfinite(array[:, :3]).all(axis=1)
    array = array[finite]
    intensity = array[:, 3].copy() if array.shape[1] > 3 else np.zeros(array.shape[0])
    return Cloud(frame, np.ascontiguousarray(array[:, :3]), intensity)


def _read_pcd(path: Path) -> Cloud:
    from pypcd4 import PointCloud

    cloud = PointCloud.from_path(path)
    fields = list(cloud.fields)
    missing = [f for f in ("x", "y", "z") if f not in fields]
    if missing:
        raise PointCloudError(f"{path}: the PCD has no {', '.join(missing)} field")
    data = cloud.pc_data
    xyz = np.stack([np.asarray(data[f], dtype=np.float64) for f in ("x", "y", "z")], axis=1)
    intensity = (np.asarray(data["intensity"], dtype=np.float64) if "intensity" in fields
                 else np.zeros(xyz.shape[0]))
    rings = np.asarray(data["ring"], dtype=np.int64) if "ring" in fields else None
    finite = np.isfinite(xyz).all(axis=1)
    return Cloud(path.stem, xyz[finite], intensity[finite],
                 None if rings is None else rings[finite])


def read_labels(path: str | Path) -> NDArray[np.float64]:
    """The cones of one KITTI label file, (M, 3) x, y, z in m (LiDAR frame).

    Lines of other classes, lines too short to carry a position, and labels at the origin
    (the labelling tool's placeholder, not a cone) are left out.
    """
    rows: list[tuple[float, float, float]] = []
    for line in Path(path).read_text(errors="replace").splitlines():
        parts = line.split()
        if len(parts) < 14 or parts[0] not in CONE_CLASSES:
            continue
        try:
            x, y, z = float(parts[11]), float(parts[12]), float(parts[13])
        except ValueError:
            continue
        if abs(x) < 1e-6 and abs(y) < 1e-6:
            continue
        rows.append((x, y, z))
    return np.asarray(rows, dtype=np.float64).reshape(-1, 3)


@dataclass(slots=True)
class MetadataReport:
    """What a scene's ``metadata.json`` held: entries read, and what was wrong with it."""

    present: bool = False
    frames: int = 0
    """Valid, distinct frame entries."""
    duplicates: int = 0
    syntax_errors: int = 0
    """Places where the JSON was broken (the entries around them are still read)."""
    missing_files: int = 0
    """Valid entries whose point file does not exist."""

    def as_dict(self) -> dict[str, int | bool]:
        return {"present": self.present, "frames": self.frames, "duplicates": self.duplicates,
                "syntax_errors": self.syntax_errors, "missing_files": self.missing_files}


_ENTRY_START = re.compile(r'\{\s*"id"\s*:')


def read_metadata(scene: Path) -> MetadataReport:
    """Read ``scene/metadata.json`` for what is valid (see :class:`MetadataReport`).

    Each frame entry (an object with an ``id``) is decoded on its own, so a syntax error in the
    header or between entries loses nothing else.
    """
    report = MetadataReport()
    path = scene / "metadata.json"
    if not path.is_file():
        return report
    report.present = True
    text = path.read_text(errors="replace")
    try:
        json.loads(text)
    except json.JSONDecodeError as exc:
        report.syntax_errors += 1
        log.warning("%s: JSON syntax error (%s); reading the frame entries one by one", path, exc)
    decoder = json.JSONDecoder()
    seen: set[object] = set()
    for match in _ENTRY_START.finditer(text):
        try:
            entry, _ = decoder.raw_decode(text, match.start())
        except json.JSONDecodeError:
            report.syntax_errors += 1
            continue
        if not isinstance(entry, dict):
            continue
        key = entry.get("id")
        if key in seen:
            report.duplicates += 1
            continue
        seen.add(key)
        report.frames += 1
        cloud_file = (entry.get("pointcloud") or {}).get("file")
        if isinstance(cloud_file, str) and not (scene / cloud_file).is_file():
            report.missing_files += 1
    if report.duplicates or report.missing_files:
        log.warning("%s: %d duplicate frame entries, %d entries whose point file is missing",
                    path, report.duplicates, report.missing_files)
    return report


@dataclass(slots=True)
class Scene:
    """A folder of point clouds: its frame files in order, labels where there are some."""

    root: Path
    cloud_files: list[Path]
    labels_dir: Path | None
    metadata: MetadataReport = field(default_factory=MetadataReport)

    def labels(self, frame: str) -> NDArray[np.float64] | None:
        """The frame's labelled cones (M, 3), an empty array if its label file is missing,
        None if the scene has no labels at all."""
        if self.labels_dir is None:
            return None
        path = self.labels_dir / f"{frame}.txt"
        return read_labels(path) if path.is_file() else np.zeros((0, 3))

    def clouds(self, skipped: list[str] | None = None) -> Iterator[Cloud]:
        """Each readable cloud in frame order; an unreadable one is named in one log line,
        appended to ``skipped`` and passed over."""
        for path in self.cloud_files:
            try:
                yield read_cloud(path)
            except PointCloudError as exc:
                log.warning("skipped: %s", exc)
                if skipped is not None:
                    skipped.append(path.name)


def open_scene(path: str | Path) -> Scene:
    """A scene folder (``points/`` inside it, or the clouds directly in it).

    Raises :class:`PointCloudError` with one line for a missing or empty folder, or one that
    holds no point cloud files.
    """
    root = Path(path)
    if not root.is_dir():
        raise PointCloudError(f"{root}: no such folder")
    points_dir = root / "points" if (root / "points").is_dir() else root
    files = sorted(p for p in points_dir.iterdir()
                   if p.is_file() and p.suffix.lower() in CLOUD_SUFFIXES)
    if not files:
        kinds = sorted({p.suffix or p.name for p in points_dir.iterdir()})[:5]
        what = f"it holds {', '.join(kinds)}" if kinds else "it is empty"
        raise PointCloudError(f"{points_dir}: no point cloud files ({', '.join(CLOUD_SUFFIXES)}); "
                              f"{what}")
    labels_dir = root / "labels" if (root / "labels").is_dir() else None
    return Scene(root, files, labels_dir, read_metadata(root))
