"""tools/hairpin_line_figure.py draws the picture in docs/driving.md from the planner itself."""

from __future__ import annotations

import importlib.util
from pathlib import Path

from PIL import Image

ROOT = Path(__file__).resolve().parents[1]


def test_the_hairpin_figure_is_drawn(tmp_path: Path) -> None:
    spec = importlib.util.spec_from_file_location(
        "hairpin_line_figure", ROOT / "tools" / "hairpin_line_figure.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    out = tmp_path / "hairpin.png"
    module.draw(out)  # raises when the planner makes no line through the hairpin
    with Image.open(out) as image:
        assert image.format == "PNG"
        assert image.size[0] > 400 and image.size[1] > 300
