"""The shipped Foxglove layout is the one the code builds, and every topic and field it plots
exists in the schema the live view and the recording carry."""

from __future__ import annotations

import json
from typing import Any

from recordings.foxglove_layout import LAYOUT_PATH, layout_json
from recordings.live_server import LIVE_TOPIC_CLASSES


def _panels(node: dict[str, Any]) -> list[dict[str, Any]]:
    if node.get("type") == "panel":
        return [node]
    return [p for item in node.get("items", []) for p in _panels(item["content"])]


def _resolve(path: str) -> None:
    """``/topic.field.sub`` names a field of the topic's protobuf message."""
    topic = next(t for t in sorted(LIVE_TOPIC_CLASSES, key=len, reverse=True)
                 if path.startswith(t + "."))
    descriptor = LIVE_TOPIC_CLASSES[topic].DESCRIPTOR
    for name in path[len(topic) + 1:].split("."):
        field = descriptor.fields_by_name.get(name)
        assert field is not None, f"{path}: no field {name!r} in {descriptor.full_name}"
        descriptor = field.message_type


def test_shipped_layout_is_the_built_one() -> None:
    assert LAYOUT_PATH.read_text() == layout_json(), \
        "regenerate with: python -m recordings.foxglove_layout"


def test_layout_panels_use_served_topics_and_fields() -> None:
    layout = json.loads(LAYOUT_PATH.read_text())
    panels = _panels(layout["content"])
    kinds = [p["panelType"] for p in panels]
    assert kinds.count("ThreeDee") == 1 and kinds.count("Plot") == 4
    scene = next(p for p in panels if p["panelType"] == "ThreeDee")
    assert scene["config"]["topics"]["/foxglove/scene"]["visible"] is True
    series = [s["value"] for p in panels for s in p["config"].get("paths", [])]
    assert "/plan.target_speed_mps" in series and "/eval/pose_error.position_m" in series
    for value in series:
        _resolve(value)
