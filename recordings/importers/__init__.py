"""Importers of foreign vehicle logs: each reads one format into an :class:`ImportedLog`.

A format is a function ``load(source_dir, drop_gnss) -> ImportedLog`` registered by name in
:data:`IMPORTERS`; ``python main.py import NAME SOURCE --out X.mcap`` writes what it returns as a
recording (the wire bytes are made by the orchestrator, which may use the sensors' encoders).
To add a format, write ``recordings/importers/<name>.py`` with a ``load`` and add it here.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from recordings.importers import comma2k19
from recordings.importers.base import GnssOutage, ImportedLog

Importer = Callable[[Path, GnssOutage | None], ImportedLog]
"""``load(source, drop_gnss)``: ``drop_gnss`` an outage to leave out (or None)."""

#: Importer of each format, by the name the ``import`` command takes.
IMPORTERS: dict[str, Importer] = {
    "comma2k19": comma2k19.load,
}

__all__ = ["IMPORTERS", "GnssOutage", "ImportedLog", "Importer"]
