"""The Foxglove layout shipped with the stack (``recordings/foxglove/layout.json``): one layout
for the live view (``--live``) and for recordings, since both carry the same topics.

A 3D panel on the scene (``/foxglove/scene`` in the ``world`` frame, the car's ``base_link`` from
``/foxglove/tf``) beside plots of the speed against the plan's target, the steering, throttle and
brake, the pose error (simulation: ``/eval/pose_error``) and the AS state over time. Built with
the ``foxglove-sdk`` layout classes; ``python -m recordings.foxglove_layout`` writes the file
again after a change here (a test checks the two agree).
"""

from __future__ import annotations

import json
from pathlib import Path

import foxglove.layouts as fl

from recordings import topics

LAYOUT_PATH = Path(__file__).resolve().parent / "foxglove" / "layout.json"


def _plot(title: str, *series: tuple[str, str], unit: str) -> fl.PlotPanel:
    return fl.PlotPanel(
        title=title,
        config=fl.PlotConfig(
            paths=[fl.PlotSeries(value=value, label=label, enabled=True,
                                 timestamp_method="receiveTime") for value, label in series],
            show_legend=True,
            legend_display="top",
            time_window_mode="sliding",
            following_view_width=30.0,
            y_axis_label=unit,
        ),
    )


def build_layout() -> fl.Layout:
    """The layout: the 3D scene on the left, the plots stacked on the right."""
    scene = fl.ThreeDeePanel(
        title="scene",
        config=fl.ThreeDeeConfig(
            fixed_frame="world",
            follow_tf="world",
            follow_mode="follow-none",
            topics={topics.FOXGLOVE_SCENE: fl.BaseRendererSceneUpdateTopicSettings(visible=True)},
        ),
    )
    plots = [
        _plot("speed vs target", (f"{topics.MAP_STATE}.pose.vx_mps", "speed (estimate)"),
              (f"{topics.PLAN}.target_speed_mps", "target"),
              (f"{topics.TRUTH_POSE}.vx_mps", "speed (truth, sim)"), unit="m/s"),
        _plot("steering", (f"{topics.COMMAND}.steering_rad", "steering command"),
              (f"{topics.TRUTH_POSE}.steering_rad", "steering (truth, sim)"), unit="rad"),
        _plot("throttle and brake", (f"{topics.COMMAND}.throttle", "throttle"),
              (f"{topics.COMMAND}.brake", "brake"), unit="0..1"),
        _plot("pose error (sim)", (f"{topics.EVAL_POSE_ERROR}.position_m", "position m"),
              (f"{topics.EVAL_POSE_ERROR}.heading_rad", "heading rad"), unit="m, rad"),
    ]
    as_state = fl.StateTransitionsPanel(
        title="AS state",
        config=fl.StateTransitionsConfig(
            paths=[fl.StateTransitionsSeries(value=f"{topics.COMMAND}.state", label="AS state",
                                             timestamp_method="receiveTime")],
        ),
    )
    right = fl.SplitContainer(
        direction="column",
        items=[fl.SplitItem(content=panel) for panel in [*plots, as_state]],
    )
    return fl.Layout(content=fl.SplitContainer(direction="row", items=[
        fl.SplitItem(proportion=3, content=scene),
        fl.SplitItem(proportion=2, content=right),
    ]))


def layout_json() -> str:
    """The layout as the JSON text shipped (indented, one key order)."""
    return json.dumps(json.loads(build_layout().to_json()), indent=2, sort_keys=True) + "\n"


if __name__ == "__main__":
    LAYOUT_PATH.write_text(layout_json())
