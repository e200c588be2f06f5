"""Checked numeric option types for the command line (argparse ``type=`` functions).

Every numeric option of every subcommand uses one of these instead of a bare ``int`` or
``float``, so a value outside its range (``sim --laps -3``, ``replay --rate 0``, ``record
--seconds nan``) stops the program before anything starts, with argparse's one-line error
naming the option::

    main.py sim: error: argument --laps: must be an integer >= 1, got '-3'

Each function takes the option's text and returns the value, or raises
:class:`argparse.ArgumentTypeError` with a one-line message. ``tests/test_cli_options.py``
walks the whole parser and fails on any option still typed ``int`` or ``float``.
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable


def _int(text: str, lowest: int, highest: int | None = None) -> int:
    what = (f"an integer in {lowest}..{highest}" if highest is not None
            else f"an integer >= {lowest}")
    try:
        value = int(text, 10)
    except (TypeError, ValueError):
        raise argparse.ArgumentTypeError(f"must be {what}, got {text!r}") from None
    if value < lowest or (highest is not None and value > highest):
        raise argparse.ArgumentTypeError(f"must be {what}, got {text!r}")
    return value


def _float(text: str, lowest: float, inclusive: bool, unit: str) -> float:
    what = f"a number {'>=' if inclusive else '>'} {lowest:g}{unit}"
    try:
        value = float(text)
    except (TypeError, ValueError):
        raise argparse.ArgumentTypeError(f"must be {what}, got {text!r}") from None
    if not math.isfinite(value) or value < lowest or (value == lowest and not inclusive):
        raise argparse.ArgumentTypeError(f"must be {what} (finite), got {text!r}")
    return value


def positive_int(text: str) -> int:
    """An integer >= 1 (laps, counts, repetitions, jobs)."""
    return _int(text, 1)


def non_negative_int(text: str) -> int:
    """An integer >= 0 (seeds, thread counts where 0 means the default)."""
    return _int(text, 0)


def int_in(lowest: int, highest: int) -> Callable[[str], int]:
    """A type function accepting integers in ``lowest..highest`` (both included)."""

    def check(text: str) -> int:
        return _int(text, lowest, highest)

    check.__name__ = f"int_in_{lowest}_{highest}"
    return check


def positive_float(text: str) -> float:
    """A finite number > 0 (rates, frame rates, lengths in m)."""
    return _float(text, 0.0, inclusive=False, unit="")


def non_negative_float(text: str) -> float:
    """A finite number >= 0 (noise levels, margins)."""
    return _float(text, 0.0, inclusive=True, unit="")


def positive_seconds(text: str) -> float:
    """A finite duration > 0 s."""
    return _float(text, 0.0, inclusive=False, unit=" s")


def stall_window(text: str) -> tuple[float, float]:
    """A window ``T:D`` of a clock: a start T >= 0 s and a duration D > 0 s."""
    start, sep, duration = text.partition(":")
    if not sep:
        raise argparse.ArgumentTypeError(f"must be T:D (start and duration, s), got {text!r}")
    return (_float(start, 0.0, inclusive=True, unit=" s"),
            _float(duration, 0.0, inclusive=False, unit=" s"))


def size_wxh(text: str, smallest_px: int = 16) -> tuple[int, int]:
    """A frame size ``WxH`` in pixels, each side >= ``smallest_px``."""
    try:
        width_px, height_px = (int(v, 10) for v in text.lower().split("x"))
    except (TypeError, ValueError):
        raise argparse.ArgumentTypeError(
            f"must be a size WxH, e.g. 1280x720, got {text!r}") from None
    if width_px < smallest_px or height_px < smallest_px:
        raise argparse.ArgumentTypeError(
            f"must be a size WxH with both sides >= {smallest_px} px, got {text!r}")
    return width_px, height_px


def seed_list(text: str) -> list[int]:
    """Seeds as ``1-6`` or ``1,3,5`` or a mix (``0-2,7``): integers >= 0, ranges ascending."""
    seeds: list[int] = []
    for part in text.split(","):
        lo, dash, hi = part.strip().partition("-")
        try:
            first = int(lo, 10)
            last = int(hi, 10) if dash else first
        except ValueError:
            raise argparse.ArgumentTypeError(
                f"must be seeds such as 1-6 or 1,3,5 (integers >= 0), got {text!r}") from None
        if first < 0 or last < first:
            raise argparse.ArgumentTypeError(
                f"must be seeds such as 1-6 or 1,3,5 (integers >= 0, ranges ascending), "
                f"got {text!r}")
        seeds.extend(range(first, last + 1))
    return seeds


def host_port(text: str) -> tuple[str, int]:
    """``[HOST:]PORT`` (``8765``, ``0.0.0.0:8765``, ``[::1]:8765``) -> (host, port); the host
    defaults to 127.0.0.1 (this machine only); port 0 picks a free one."""
    host, sep, port_text = text.rpartition(":")
    host = host.strip("[]") if sep else ""
    try:
        port = int(port_text, 10)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"must be [HOST:]PORT with PORT an integer in 0..65535, got {text!r}") from None
    if not 0 <= port <= 65535 or (sep and not host) or any(c.isspace() for c in host):
        raise argparse.ArgumentTypeError(
            f"must be [HOST:]PORT with PORT an integer in 0..65535, got {text!r}")
    return host or "127.0.0.1", port


CHECKED_TYPES: tuple[Callable[..., object], ...] = (
    positive_int, non_negative_int, positive_float, positive_seconds, size_wxh, seed_list,
    host_port)
"""The checked types of this module (``int_in`` makes more)."""
