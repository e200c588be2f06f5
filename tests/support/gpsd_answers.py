"""gpsd's answer keys (the ``.chk`` files beside the shared NMEA captures): the fixes it
reported, as its JSON ``TPV`` reports with a 2D or 3D fix and a position."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any


def gpsd_fixes(chk: Path) -> list[dict[str, Any]]:
    """Every fix gpsd reported for a capture, in order (its JSON objects)."""
    fixes = []
    for line in chk.read_text(errors="replace").splitlines():
        if not line.startswith("{"):
            continue
        try:
            obj = json.loads(line)
        except json.JSONDecodeError:
            continue
        if obj.get("class") == "TPV" and obj.get("mode", 0) >= 2 and "lat" in obj:
            fixes.append(obj)
    return fixes
