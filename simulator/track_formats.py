"""Track files: the EUFS CSV and AMZ FSSIM YAML formats, read into a :class:`RawLayout`.

EUFS CSV rows are ``tag,x,y,direction,x_variance,y_variance,xy_covariance`` (a ``car_start``
row is the start pose; EPFL's track database names its columns ``cone_type,X,Y,...``); FSSIM
YAML has ``cones_left`` / ``cones_right`` / ``cones_orange`` / ``cones_orange_big`` and
``starting_pose_front_wing``. Real files vary (repeated header rows, no start pose, unordered
cones, a cone written twice); what cannot be read raises :class:`common.errors.TrackError`
naming the file, the line and what is wrong.
"""

from __future__ import annotations

import logging
import math
from pathlib import Path

import numpy as np
import yaml

from common.errors import TrackError
from common.messages import ConeColour, ConeSize
from common.polyline import FloatArray
from simulator.track_layouts import RawLayout

log = logging.getLogger(__name__)

FRONT_WING_TO_ORIGIN_M = 2.25
"""Distance from the front of the default car back to the vehicle origin (rear axle), used to
turn FSSIM's ``starting_pose_front_wing`` into the start pose (length 2.9 - rear overhang 0.65)."""

_EUFS_TAGS: dict[str, tuple[ConeColour, ConeSize]] = {
    "blue": (ConeColour.BLUE, ConeSize.SMALL),
    "yellow": (ConeColour.YELLOW, ConeSize.SMALL),
    "orange": (ConeColour.ORANGE, ConeSize.SMALL),
    "small_orange": (ConeColour.ORANGE, ConeSize.SMALL),
    "big_orange": (ConeColour.BIG_ORANGE, ConeSize.LARGE),
    "large_orange": (ConeColour.BIG_ORANGE, ConeSize.LARGE),
    "unknown": (ConeColour.UNKNOWN, ConeSize.SMALL),
}
_EUFS_NON_CONE_TAGS = {"car_start", "midpoint"}


_HEADER_TAG_COLUMNS = {"tag", "cone_type"}
"""A row starting with one of these is a header: EUFS and FSDS write ``tag,x,y,direction,...``,
EPFL's track database ``cone_type,X,Y,Z,std_X,...``."""


def _header_columns(path: Path, lineno: int, names: list[str]) -> tuple[int, int, int]:
    """The columns of x, y and direction (-1: none) named by a header row."""
    if "x" not in names or "y" not in names:
        raise TrackError(f"{path}:{lineno}: a header without x and y columns: {names}")
    direction = names.index("direction") if "direction" in names else -1
    return names.index("x"), names.index("y"), direction


def parse_eufs_csv(path: Path) -> RawLayout:
    """Read an EUFS CSV track file (repeated headers and blank lines are skipped; the columns
    are those its header names, ``tag,x,y,direction`` when it has none)."""
    try:
        text = path.read_text(encoding="utf-8", errors="replace")
    except OSError as exc:
        raise TrackError(f"{path}: cannot read ({exc.strerror})") from None
    xy: list[tuple[float, float]] = []
    colours: list[int] = []
    sizes: list[int] = []
    start: tuple[float, float, float] | None = None
    ix, iy, idir = 1, 2, 3
    for lineno, line in enumerate(text.splitlines(), 1):
        fields = [f.strip() for f in line.split(",")]
        if not line.strip() or line.lstrip().startswith("#"):
            continue
        tag = fields[0].lower()
        if tag in _HEADER_TAG_COLUMNS:
            ix, iy, idir = _header_columns(path, lineno, [f.lower() for f in fields])
            continue
        if len(fields) <= max(ix, iy):
            raise TrackError(f"{path}:{lineno}: expected 'tag,x,y,...', got {line.strip()!r}")
        try:
            x, y = float(fields[ix]), float(fields[iy])
            direction = float(fields[idir]) if 0 <= idir < len(fields) and fields[idir] else 0.0
        except ValueError:
            raise TrackError(f"{path}:{lineno}: x/y/direction not numbers in"
                             f" {line.strip()!r}") from None
        if not (math.isfinite(x) and math.isfinite(y)):
            raise TrackError(f"{path}:{lineno}: non-finite cone position")
        if tag == "car_start":
            if start is not None:
                log.warning("%s:%d: second car_start row ignored", path, lineno)
            else:
                start = (x, y, direction)
            continue
        if tag in _EUFS_NON_CONE_TAGS:
            continue
        if tag not in _EUFS_TAGS:
            raise TrackError(f"{path}:{lineno}: unknown tag {fields[0]!r} (expected one of"
                             f" {', '.join(sorted(_EUFS_TAGS))}, car_start, midpoint)")
        c, s = _EUFS_TAGS[tag]
        xy.append((x, y))
        colours.append(int(c))
        sizes.append(int(s))
    if not xy:
        raise TrackError(f"{path}: no cones found (is it an EUFS track CSV?)")
    return RawLayout(path.stem, str(path), np.array(xy, np.float64),
                      np.array(colours, np.int64), np.array(sizes, np.int64), start)


def parse_fssim_yaml(path: Path, car_front_to_origin_m: float = FRONT_WING_TO_ORIGIN_M
                     ) -> RawLayout:
    """Read an AMZ FSSIM track YAML; ``starting_pose_front_wing`` (x, y, yaw of the front wing)
    becomes the vehicle-origin start pose ``car_front_to_origin_m`` behind it."""
    try:
        with path.open(encoding="utf-8") as fh:
            data = yaml.safe_load(fh)
    except OSError as exc:
        raise TrackError(f"{path}: cannot read ({exc.strerror})") from None
    except yaml.YAMLError as exc:
        raise TrackError(f"{path}: not valid YAML ({exc})") from None
    if not isinstance(data, dict):
        raise TrackError(f"{path}: expected a YAML mapping with cones_left/cones_right")
    keys = (("cones_left", ConeColour.BLUE, ConeSize.SMALL, 1),
            ("cones_right", ConeColour.YELLOW, ConeSize.SMALL, -1),
            ("cones_orange", ConeColour.ORANGE, ConeSize.SMALL, 0),
            ("cones_orange_big", ConeColour.BIG_ORANGE, ConeSize.LARGE, 0))
    if not any(k in data for k, *_ in keys):
        raise TrackError(f"{path}: none of {', '.join(k for k, *_ in keys)} found")
    xy: list[FloatArray] = []
    colours: list[int] = []
    sizes: list[int] = []
    sides: list[int] = []
    for key, colour, size, side in keys:
        items = data.get(key) or []
        try:
            arr = np.asarray(items, np.float64).reshape(-1, 2) if len(items) else np.zeros((0, 2))
        except (ValueError, TypeError):
            raise TrackError(f"{path}: '{key}' must be a list of [x, y] pairs") from None
        if not np.all(np.isfinite(arr)):
            raise TrackError(f"{path}: '{key}' has non-finite coordinates")
        xy.append(arr)
        colours += [int(colour)] * len(arr)
        sizes += [int(size)] * len(arr)
        sides += [side] * len(arr)
    start: tuple[float, float, float] | None = None
    pose = data.get("starting_pose_front_wing")
    if pose is not None:
        try:
            px, py, pyaw = (float(v) for v in list(pose)[:3])
        except (ValueError, TypeError):
            raise TrackError(f"{path}: 'starting_pose_front_wing' must be [x, y, yaw]") from None
        start = (px - car_front_to_origin_m * math.cos(pyaw),
                 py - car_front_to_origin_m * math.sin(pyaw), pyaw)
    return RawLayout(path.stem, str(path), np.vstack(xy), np.array(colours, np.int64),
                      np.array(sizes, np.int64), start, np.array(sides, np.int64))
