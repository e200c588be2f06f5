"""``python main.py render X.mcap --out DIR``: frames (and a movie) of a recording's map."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from common.cli_types import positive_float, size_wxh
from common.config import AppConfig
from common.errors import FsdError


def register(subparsers: Any, common: argparse.ArgumentParser) -> None:
    """Add ``render``."""
    parser = subparsers.add_parser("render", parents=[common],
                                   help="draw a recording's map states as PNG frames (and a movie)")
    parser.add_argument("recording", type=Path, help="an .mcap recording")
    parser.add_argument("--out", type=Path, required=True, help="folder for the frames")
    parser.add_argument("--size", type=size_wxh, default=None,
                        help="frame size WxH (default 1280x720)")
    parser.add_argument("--fps", type=positive_float, default=None,
                        help="frames per second of recording time (default: every map state)")
    parser.add_argument("--view", choices=("track", "follow"), default=None,
                        help="whole track, or follow the car")
    parser.add_argument("--movie", type=Path, default=None,
                        help="also write a movie (.mp4 or .gif)")
    parser.set_defaults(func=_render)


def _render(args: argparse.Namespace, config: AppConfig) -> int:
    from visualiser.offline import render_recording

    if args.size is not None:
        config.visualiser.width_px, config.visualiser.height_px = args.size
    if args.view is not None:
        config.visualiser.view = args.view
    try:
        result = render_recording(args.recording, args.out, config, fps=args.fps,
                                  movie=args.movie, progress=sys.stderr.isatty())
    except FsdError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    print(f"{result['frames']} frames in {args.out} ({result['fps']:.1f} frames/s)"
          + (f", movie {result['movie']}" if result.get("movie") else ""))
    return 0
