"""``python main.py info X.mcap [--json]``: what a recording holds (replay/record are Main's)."""

from __future__ import annotations

import argparse
import json
import os
import sys
from typing import Any

from common.errors import RecordingError
from recordings.info import info


def register(subparsers: Any, common: argparse.ArgumentParser) -> None:
    """Add ``info``."""
    parser = subparsers.add_parser(
        "info", parents=[common],
        help="describe a recording: duration, topics with counts and rates, gaps, recovery",
    )
    parser.add_argument("path", metavar="X.mcap", help="the recording")
    parser.add_argument("--json", action="store_true", help="print the summary as JSON")
    parser.set_defaults(func=_info_command)


def _info_command(args: argparse.Namespace, config: object) -> int:
    try:
        summary = info(args.path)
    except RecordingError as exc:
        print(f"info: {exc}", file=sys.stderr)
        return 1
    code = 0
    if summary["message_count"] == 0 and summary["recovered"]:
        print(f"info: nothing readable in {args.path}: {summary['note']}", file=sys.stderr)
        if not args.json:
            return 1
        code = 1
    text = json.dumps(summary, indent=2, sort_keys=True) if args.json else format_table(summary)
    try:
        print(text, flush=True)
    except BrokenPipeError:  # piped into `head`: stop quietly
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
    return code


def format_table(summary: dict[str, Any]) -> str:
    """The human-readable form of :func:`recordings.info.info`'s result."""
    lines = [
        f"file:      {summary['path']} ({summary['size_bytes'] / 1e6:.2f} MB, "
        f"{summary['chunk_count']} chunks)",
        f"duration:  {summary['duration_s']:.3f} s "
        f"({summary['start_time_s']:.3f} .. {summary['end_time_s']:.3f} s)",
        f"messages:  {summary['message_count']}",
    ]
    if summary["recovered"]:
        lines.append(f"recovered: yes: {summary['note']}")
    else:
        lines.append("recovered: no (complete file)")
    for name, data in summary["metadata"].items():
        keys = ", ".join(sorted(data))
        lines.append(f"metadata:  {name}: {keys}")
    lines.append("")
    width = max([len("topic")] + [len(t) for t in summary["topics"]])
    lines.append(f"{'topic':<{width}}  {'count':>8}  {'rate_hz':>9}  {'max_gap_s':>9}  schema")
    for topic, data in summary["topics"].items():
        lines.append(
            f"{topic:<{width}}  {data['count']:>8d}  {data['rate_hz']:>9.2f}  "
            f"{data['max_gap_s']:>9.3f}  {data['schema']}"
        )
    if summary["gap_count"]:
        lines.append("")
        lines.append(f"gaps over 1 s: {summary['gap_count']}")
        for gap in summary["gaps"]:
            lines.append(
                f"  {gap['topic']}: {gap['gap_s']:.3f} s from {gap['start_s']:.3f} s to "
                f"{gap['end_s']:.3f} s"
            )
        if summary["gap_count"] > len(summary["gaps"]):
            lines.append(f"  ... {summary['gap_count'] - len(summary['gaps'])} more")
    return "\n".join(lines)
