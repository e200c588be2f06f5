"""``python main.py bench gpsd CAPTURE...``: how many of gpsd's fixes ``decode nmea`` reports on
NMEA captures, per receiver cycle, and how many fixes it reports that gpsd does not (issue 44).

gpsd's answer for a capture is ``CAPTURE.chk`` beside it when there is one (gpsd's regression
files, as ``../shared/data/nmea`` holds them), else gpsd itself: the capture played once through
``gpsfake`` (Debian: ``apt install gpsd gpsd-clients``). A team points this at its own
receiver's logs to learn whether our receiver reads them as gpsd does before it drives on them.
The reference is gpsd, run in the same command; the last line gives the ratio asked for.
"""

from __future__ import annotations

import argparse
import json
import logging
import sys
from pathlib import Path

from common.cli_types import non_negative_int
from orchestrator.config import AppConfig
from orchestrator.progress import Progress
from sensors.cli import decode_nmea_file
from sensors.gpsd_agreement import Agreement, GpsfakeError, agreement, gpsfake_reports

HELP = "NMEA captures against gpsd: cycles found, extra fixes"

log = logging.getLogger(__name__)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of the benchmark."""
    parser.add_argument("captures", nargs="+", type=Path, metavar="CAPTURE",
                        help="NMEA capture files (a CAPTURE.chk beside one is gpsd's answer)")
    parser.add_argument("--gpsfake", default="gpsfake",
                        help="the gpsfake to run where no .chk is beside a capture")
    parser.add_argument("--show-extra", type=non_negative_int, default=3, metavar="N",
                        help="print up to N of each capture's extra fixes (default 3)")


def _reports(capture: Path, gpsfake: str) -> tuple[str, str]:
    """gpsd's report stream for ``capture`` and where it came from."""
    chk = capture.with_name(capture.name + ".chk")
    if chk.is_file():
        return chk.read_text(errors="replace"), "chk"
    return gpsfake_reports(capture, gpsfake), "gpsfake"


def run(args: argparse.Namespace, config: AppConfig) -> int:
    """Compare each capture; print one row each, then the totals."""
    missing = [str(p) for p in args.captures if not p.is_file()]
    if missing:
        print(f"bench gpsd: no such file: {', '.join(missing)}", file=sys.stderr)
        return 2
    progress = Progress("bench gpsd", len(args.captures), "captures", bar=sys.stderr.isatty())
    total = Agreement(0, 0)
    failed = 0
    print(f"{'capture':40s} {'answer':8s} {'gpsd':>6s} {'found':>6s} {'extra':>6s}")
    for done, capture in enumerate(args.captures):
        progress.update(done, capture.name)
        try:
            reports, source = _reports(capture, args.gpsfake)
        except GpsfakeError as exc:
            log.error("%s", exc)
            failed += 1
            continue
        fixes = [obj for obj in decode_nmea_file(capture) if "counts" not in obj]
        result = agreement(reports, fixes)
        total.cycles += result.cycles
        total.found += result.found
        total.extra += result.extra
        progress.write(f"{capture.name:40s} {source:8s} {result.cycles:6d} {result.found:6d} "
                       f"{len(result.extra):6d}")
        for fix in result.extra[:args.show_extra]:
            progress.write(f"    extra: {json.dumps(fix)}")
    progress.update(len(args.captures))
    progress.close()
    ratio = total.found / total.cycles if total.cycles else float("nan")
    print(f"captures={len(args.captures) - failed} failed={failed} gpsd_cycles={total.cycles} "
          f"found={total.found} extra={len(total.extra)} found_ratio={ratio:.4f}")
    return 1 if failed else 0
