"""Frames explain themselves: lap times from the plan's lap counter, the trace coloured by speed
with its scale, the AS state on its ASSI colour, a legend of what is drawn."""

from __future__ import annotations

import numpy as np
import pytest

from common.messages import ActuatorCommand, AsState, ConeColour, ConeMap, MapState, PoseEstimate
from visualiser import annotations as ann
from visualiser.frame_data import frame_from_messages
from visualiser.laps import LapTimer
from visualiser.renderer import legend_items
from visualiser.visualiser import FrameRenderer


def test_lap_timer_starts_when_the_car_moves_in_driving() -> None:
    timer = LapTimer()
    timer.observe(0.0, 0, False, 0.0)  # exploration over, standing
    timer.observe(5.0, 0, True, 0.0)  # DRIVING, not moving yet
    timer.observe(8.0, 0, True, 0.5)  # moves: lap 1 starts
    timer.observe(30.0, 0, True, 9.0)
    timer.observe(33.1, 1, True, 9.0)  # lap 1 done
    timer.observe(57.0, 2, True, 9.0)  # lap 2 done
    assert timer.lap == 2
    assert timer.lap_times_s == pytest.approx([25.1, 23.9])
    assert timer.last_s == pytest.approx(23.9)
    assert timer.best_s == pytest.approx(23.9)


def test_speed_scale_and_colours() -> None:
    assert ann.speed_scale_mps(np.array([0.0, 3.2])) == 5.0
    assert ann.speed_scale_mps(np.array([11.9, np.nan])) == 15.0
    assert ann.speed_scale_mps(np.array([np.nan])) == 5.0
    colours = ann.speed_colours(np.array([0.0, 15.0]), 15.0)
    lut = ann._lut()
    assert colours[0].tolist() == lut[0].tolist()
    assert colours[1].tolist() == lut[-1].tolist()


def test_lap_lines() -> None:
    assert ann.lap_lines(0, 10, ()) == ["lap 0 / 10", "last  -", "best  -"]
    assert ann.lap_lines(2, 0, (25.31, 24.9)) == ["lap 2", "last 24.90 s", "best 24.90 s"]


def _frame(state: AsState) -> tuple[FrameRenderer, object]:
    xy = np.array([[0.0, 4.0], [20.0, 4.0], [0.0, -4.0], [20.0, -4.0]])
    cones = ConeMap(xy, np.tile(np.eye(2) * 1e-4, (4, 1, 1)),
                    [ConeColour.BLUE, ConeColour.BLUE, ConeColour.YELLOW, ConeColour.YELLOW],
                    [1, 1, 1, 1], np.ones(4), np.arange(4))
    pose = PoseEstimate(3.0, 10.0, 0.0, 0.0, 12.0, covariance=np.diag([0.01, 0.01, 0.001]))
    frame = frame_from_messages(MapState(3.0, pose, cones, True, "test"), None,
                                ActuatorCommand(3.0, 0.2, 0.0, 0.0, state))
    frame.trace_xy_m = np.column_stack([np.linspace(0.0, 9.0, 10), np.zeros(10)])
    frame.trace_speed_mps = np.linspace(0.0, 12.0, 10)
    frame.lap, frame.laps_target, frame.lap_times_s = 1, 3, (25.0,)
    return FrameRenderer(1280, 720), frame


@pytest.mark.parametrize(("state", "rgb"), [(AsState.DRIVING, ann.AS_STATE_RGB["DRIVING"]),
                                            (AsState.FINISHED, ann.AS_STATE_RGB["FINISHED"])])
def test_frame_shows_as_state_speed_trace_and_colour_bar(state: AsState,
                                                          rgb: tuple[int, int, int]) -> None:
    renderer, frame = _frame(state)
    surface = renderer.render(frame)  # type: ignore[arg-type]
    w, _ = surface.get_size()
    # The AS badge (top right) is in the ASSI colour of the state.
    badge = [tuple(surface.get_at((x, 14)))[:3] for x in range(w - 120, w - 10)]
    assert badge.count(rgb) > 20
    # Each trace segment has the colour of the speed at its end: the first (0 to 1 m) 1.33 m/s,
    # the last (9 to 10 m, to the car) 12 m/s on the 0..15 m/s scale.
    view = renderer.view_for(frame)  # type: ignore[arg-type]
    lut = ann._lut()
    slow = np.round(view.to_px([0.5, 0.0])).astype(int)
    near = {tuple(surface.get_at((int(slow[0]), int(slow[1]) + d)))[:3] for d in (-1, 0, 1)}
    assert tuple(ann.speed_colours(np.array([12.0 / 9.0]), 15.0)[0].tolist()) in near
    fast = np.round(view.to_px([9.5, 0.0])).astype(int)
    near = {tuple(surface.get_at((int(fast[0]), int(fast[1]) + d)))[:3] for d in (-1, 0, 1)}
    assert tuple(ann.speed_colours(np.array([12.0]), 15.0)[0].tolist()) in near
    # The colour bar on the right edge runs through the colour map, top to bottom.
    column = [tuple(surface.get_at((x, 360)))[:3] for x in range(w - 80, w)]
    assert any(np.abs(np.array(c) - lut[len(lut) // 2]).max() <= 12 for c in column)


def test_legend_lists_what_is_drawn() -> None:
    _, frame = _frame(AsState.DRIVING)
    texts = [text for text, _, _ in legend_items(frame, truth=False, speed_trace=True)]  # type: ignore[arg-type]
    assert "blue cone (left)" in texts and "yellow cone (right)" in texts
    assert "driven trace, by speed" in texts
    assert "true cone (sim)" not in texts and "chosen manoeuvre" not in texts
