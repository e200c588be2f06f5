"""The ``tune`` subcommand (filled in by :mod:`scale.tune`)."""

from __future__ import annotations

import argparse
from collections.abc import Callable
from typing import Any


def register_tune(subparsers: Any, common: argparse.ArgumentParser,
                  run_arguments: Callable[..., None], engine_arguments: Callable[..., None]
                  ) -> None:
    """Add ``tune``."""
