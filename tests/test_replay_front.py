"""The replay front end's messages to Main: what it sends comes back equal, and nothing but
the stack's own message types can be loaded from the stream (no code runs from it)."""

from __future__ import annotations

import os
import pickle

import numpy as np
import pytest

from common.messages import (
    ConeColour,
    ConeDetection,
    ConeSize,
    Health,
    ImuSample,
    LidarCones,
    SourceHealth,
)
from common.track import TrackLayout
from orchestrator.replay_front import (
    FrontEndTimes,
    TickInput,
    _message_pickler,
    load_tick_message,
)


def test_tick_batch_round_trips() -> None:
    health = Health(1.0, (SourceHealth(1.0, "imu", True, 200.0, 0.004, 0, False, (("x", 2),)),))
    cones = LidarCones(1.0, (ConeDetection(0.95, 4.0, 1.5, ConeColour.BLUE, ConeSize.SMALL, 0.9,
                                           0.3, 0.2),),
                       0.9, 20000)
    track = TrackLayout(name="t", cones_xy_m=np.arange(6.0).reshape(3, 2),
                        colours=np.array([1, 2, 3]), sizes=np.array([1, 1, 2]),
                        centreline_xy_m=np.zeros((4, 2)), left_xy_m=np.zeros((0, 2)),
                        right_xy_m=np.zeros((0, 2)), width_m=3.0, is_loop=True,
                        lap_length_m=10.0)
    batch = [TickInput(1.0, [ImuSample(0.995, 0.1, 0.2, 9.81, 0.0, 0.0, 0.3), cones], health,
                       track=track)]
    kind, back = load_tick_message(_message_pickler()(("ticks", batch)))
    assert kind == "ticks" and len(back) == 1
    tick = back[0]
    assert tick.t_s == 1.0 and tick.health == health
    assert tick.readings[0] == batch[0].readings[0]
    assert tick.readings[1] == cones and tick.readings[1].cones[0].colour is ConeColour.BLUE
    assert np.array_equal(tick.track.cones_xy_m, track.cones_xy_m)
    kind, times = load_tick_message(_message_pickler()(("done", FrontEndTimes(0.5, 1.5, 3))))
    assert kind == "done" and times == FrontEndTimes(0.5, 1.5, 3)


class _Exploit:
    def __reduce__(self) -> tuple[object, tuple[str]]:
        return os.system, ("echo should never run",)


@pytest.mark.parametrize("payload", [_Exploit(), pickle.loads, {"a": print}])
def test_foreign_globals_are_refused(payload: object) -> None:
    data = pickle.dumps(("ticks", payload))
    with pytest.raises(pickle.UnpicklingError, match="refusing to load"):
        load_tick_message(data)
