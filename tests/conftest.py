"""Test-wide settings: single-threaded BLAS (as main.py sets), headless SDL and matplotlib;
the ``shared_data`` and ``slow`` markers, and the files with slow tests handed out first."""

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
    config.addinivalue_line(
        "markers", "slow: about 5 s or more on one core (a closed-loop drive, a Ray start, a "
        "Monte Carlo band); pytest -m 'not slow' leaves them out")


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Files with the most slow tests first, then the files with the most tests, each file's
    tests in their own order. The workers (pytest-xdist, a file to a worker, told not to reorder)
    take files in this order, so no long file is left to run alone at the end."""
    slow: dict[str, int] = {}
    count: dict[str, int] = {}
    for item in items:
        path = str(item.path)
        count[path] = count.get(path, 0) + 1
        slow[path] = slow.get(path, 0) + (item.get_closest_marker("slow") is not None)
    files = sorted(count, key=lambda path: (-slow[path], -count[path]))
    rank = {path: index for index, path in enumerate(files)}
    items.sort(key=lambda item: rank[str(item.path)])  # stable: a file keeps its order


def pytest_runtest_setup(item: pytest.Item) -> None:
    for mark in item.iter_markers("shared_data"):
        for relative in mark.args:
            shared_data(*Path(relative).parts)
