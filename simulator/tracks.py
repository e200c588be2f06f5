"""Tracks by name or file: ``"default"``, ``"gen:SEED"``, an EUFS ``.csv`` or FSSIM ``.yaml``.

Every track is in the WORLD frame: the car starts at (0, 0) facing +x. The pieces:
:mod:`simulator.track` (the Track and its queries), :mod:`simulator.track_formats` (the
files), :mod:`simulator.track_layouts` (a Track from cones), :mod:`simulator.track_generator`
(generated and default layouts), :mod:`common.polyline` (the geometry).
"""

from __future__ import annotations

from pathlib import Path

from common.errors import TrackError
from simulator.track import Track
from simulator.track_formats import parse_eufs_csv, parse_fssim_yaml
from simulator.track_generator import default_track, generate_track
from simulator.track_layouts import build_track

SHARED_TRACKS = Path(__file__).resolve().parents[2] / "shared" / "data" / "tracks"
"""The shared track files beside the repository (``../shared/data/tracks``): a bare file name
such as ``FSG.yaml``, or ``FSG`` without its suffix, is looked up there."""

YAML_SUFFIXES = (".yaml", ".yml")
"""The suffixes of FSSIM track files."""
TRACK_SUFFIXES = (".csv", *YAML_SUFFIXES)
"""The suffixes of the track files :func:`load_track` reads."""


def find_shared_track(name: str, root: Path = SHARED_TRACKS) -> Path | None:
    """The one file called ``name`` under ``root`` (searched recursively; a ``name`` without a
    track file's suffix matches ``name.csv``, ``name.yaml`` and ``name.yml``), None when there
    is none; :class:`TrackError` when several are."""
    if not root.is_dir():
        return None
    names = [name] if Path(name).suffix.lower() in TRACK_SUFFIXES else [
        name + suffix for suffix in TRACK_SUFFIXES]
    found = sorted(path for pattern in names for path in root.rglob(pattern))
    if len(found) > 1:
        listed = ", ".join(str(p.relative_to(root)) for p in found)
        raise TrackError(f"track {name!r}: several files of that name under {root}: {listed}; "
                         f"give the path")
    return found[0] if found else None


def load_track(name_or_path: str) -> Track:
    """A track by name: ``"default"``, ``"gen:SEED"`` (a generated trackdrive), ``"hard:NAME"``
    (:mod:`simulator.hard_tracks`), or a path to an EUFS ``.csv`` or AMZ FSSIM ``.yaml`` file;
    a bare file name that is not in the working directory (with or without its suffix: ``FSG``)
    is looked up in :data:`SHARED_TRACKS`. Raises :class:`TrackError` with a clear message."""
    if name_or_path == "default":
        return default_track()
    if name_or_path.startswith("gen:"):
        try:
            seed = int(name_or_path[4:])
        except ValueError:
            raise TrackError(f"track {name_or_path!r}: expected gen:SEED with an integer seed"
                             ) from None
        if seed < 0:
            raise TrackError(f"track {name_or_path!r}: the seed of gen:SEED must be >= 0")
        return generate_track(seed)
    if name_or_path.startswith("hard:"):
        from simulator.hard_tracks import hard_track

        return hard_track(name_or_path[5:])
    path = Path(name_or_path)
    if not path.exists() and path.name == name_or_path:
        path = find_shared_track(name_or_path) or path
    if not path.exists():
        raise TrackError(f"track {name_or_path!r}: no such file (use 'default', 'gen:SEED',"
                         f" a .csv / .yaml track file, or the name of one in {SHARED_TRACKS},"
                         f" such as FSG)")
    suffix = path.suffix.lower()
    if suffix == ".csv":
        raw = parse_eufs_csv(path)
    elif suffix in YAML_SUFFIXES:
        raw = parse_fssim_yaml(path)
    else:
        raise TrackError(f"{path}: unknown track format {suffix!r} (expected .csv or .yaml)")
    return build_track(raw)
