"""The ``camera-dead`` fault: no camera datagrams (so no cone colours) while it is active; the
other sensors go on, and the camera comes back when a fault with a duration ends."""

from __future__ import annotations

import pytest

from common.errors import ConfigError
from common.messages import ConeColour, RawBytes
from orchestrator.config import AppConfig
from sensors.camera_codec import decode_camera_cones
from simulator.faults import KINDS, Fault, parse_fault
from simulator.tracks import load_track
from simulator.world import SimWorld


def _camera_times(sensors: list[str], faults: list[str], until_s: float
                  ) -> tuple[list[float], list[RawBytes], int]:
    """Arrival times and datagrams of the camera over ``until_s`` of a standing car, and the
    number of other units."""
    world = SimWorld(AppConfig(), load_track("default"), seed=2, faults=faults, sensors=sensors)
    camera: list[RawBytes] = []
    others = 0
    k = 0
    while world.t_s < until_s - 1e-9:
        k += 1
        for unit in world.step_to(0.05 * k):
            if isinstance(unit, RawBytes) and unit.source == "camera":
                camera.append(unit)
            else:
                others += 1
    return [u.timestamp_s for u in camera], camera, others


def test_camera_dead_is_a_fault_kind() -> None:
    assert "camera-dead" in KINDS
    assert parse_fault("camera-dead@0") == Fault("camera-dead", 0.0)
    assert parse_fault("camera-dead@12:3.5") == Fault("camera-dead", 12.0, 3.5)
    with pytest.raises(ConfigError):
        parse_fault("camera-dead@-1")


def test_camera_sends_nothing_while_dead_and_comes_back() -> None:
    times, datagrams, _ = _camera_times(["camera"], ["camera-dead@1:2"], 4.0)
    before = [t for t in times if t < 1.0]
    during = [t for t in times if 1.0 <= t < 3.0]
    after = [t for t in times if t >= 3.0]
    assert before and after  # the camera works outside the fault
    assert during == []
    coloured = {c.colour for d in datagrams for c in decode_camera_cones(d.payload).cones}
    assert coloured & {ConeColour.BLUE, ConeColour.YELLOW}  # cone colours come from the camera


def test_camera_dead_from_start_to_end_sends_nothing_and_spares_the_others() -> None:
    times, _, others = _camera_times(["camera", "can"], ["camera-dead@0"], 2.0)
    assert times == []
    assert others > 0  # CAN frames still flow
    times, _, _ = _camera_times(["camera"], [], 2.0)
    assert len(times) >= 10  # without the fault: 20 Hz
