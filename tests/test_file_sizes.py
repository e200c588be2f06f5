"""One file about one thing: no product file grows past 600 lines (generated protobuf aside)."""

from __future__ import annotations

from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("common", "orchestrator", "sensors", "mapper", "planner", "controller", "visualiser",
            "recordings", "simulator", "bench")
MAX_LINES = 600


def test_no_product_file_over_600_lines() -> None:
    files = [ROOT / "main.py"] + [p for package in PACKAGES for p in (ROOT / package).rglob("*.py")
                                  if not p.name.endswith("_pb2.py")]
    assert len(files) > 100
    long = {str(p.relative_to(ROOT)): n for p in files
            if (n := len(p.read_text().splitlines())) > MAX_LINES}
    assert long == {}
