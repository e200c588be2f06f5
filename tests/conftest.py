"""Test-wide settings: single-threaded BLAS (as main.py sets), headless SDL and matplotlib;
the ``shared_data`` marker."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from support.shared_data import shared_data

for _name in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_name, "1")
os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
os.environ.setdefault("MPLBACKEND", "Agg")


def pytest_configure(config: pytest.Config) -> None:
    config.addinivalue_line(
        "markers", "shared_data(*paths): the test reads these paths under ../shared/data; "
        "missing, it fails in CI and is skipped elsewhere (tests/support/shared_data.py)")


def pytest_runtest_setup(item: pytest.Item) -> None:
    for mark in item.iter_markers("shared_data"):
        for relative in mark.args:
            shared_data(*Path(relative).parts)
