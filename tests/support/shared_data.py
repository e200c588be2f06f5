"""The shared test data in ``../shared/data`` (next to the project): found, or a clear verdict.

Outside CI a missing file skips the test that needs it (a fresh clone without the data still
runs the rest). In CI (the environment variable ``CI`` set, as ``.ci/run`` and the usual CI
services do) it fails the test with a message naming the file: data that silently went
missing must not turn a test run green.
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

SHARED_DATA = Path(__file__).resolve().parents[3] / "shared" / "data"
"""``../shared/data`` relative to the project."""


def in_ci() -> bool:
    """True when running in CI (``CI`` set to anything but empty, 0, false or no)."""
    return os.environ.get("CI", "").strip().lower() not in ("", "0", "false", "no")


def missing(what: str) -> None:
    """Fail (in CI) or skip (elsewhere) because ``what`` is not there; never returns."""
    message = f"shared test data missing: {what} (expected under {SHARED_DATA})"
    if in_ci():
        pytest.fail(message, pytrace=False)
    pytest.skip(message)


def shared_path(*parts: str) -> Path:
    """The path under ``../shared/data``, whether it exists or not (for module constants)."""
    return SHARED_DATA.joinpath(*parts)


def shared_data(*parts: str) -> Path:
    """The existing path under ``../shared/data``; missing: :func:`missing`."""
    path = shared_path(*parts)
    if not path.exists():
        missing(str(path))
    return path


def shared_files(folder: str, pattern: str) -> list[Path]:
    """The files matching ``pattern`` in a shared folder (sorted; empty when absent). For
    parametrising; pair it with a test calling :func:`require_files` so that an empty list
    fails in CI instead of collecting no tests."""
    return sorted(shared_path(folder).glob(pattern))


def require_files(files: list[Path], what: str) -> None:
    """:func:`missing` when ``files`` is empty."""
    if not files:
        missing(what)
