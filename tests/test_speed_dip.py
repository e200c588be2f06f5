"""The speed loop and a dip in the plan's speed before its preview point
(``controller.speed_dip_margin_mps``, controller/controller.py ``_speed_control``).

EPFL ``track_3`` seed 1 with a 30 m camera: the manoeuvre, starting 0.5 m off the plan, bent
back in its first metres, its speed there 9.7 m/s and rising after; the car at 12.4 m/s read
the plan 3 m ahead, near its own speed, and its feed-forward asked to speed up. It braked at
most 18 % for 0.4 s, ran wide and hit two cones."""

from __future__ import annotations

import numpy as np
import pytest

from common.car import CarConfig
from common.messages import PoseEstimate, TargetStates
from controller.config import ControllerConfig
from controller.controller import Controller
from controller.steering import PathRef

CAR_SPEED_MPS = 12.4


def _dipping_path() -> PathRef:
    """A straight manoeuvre along x: 9.7 m/s for its first 2 m, then rising to 14 m/s by 5 m."""
    x = np.arange(0.0, 30.0, 0.5)
    speed = np.interp(x, [0.0, 2.0, 5.0, 30.0], [9.7, 9.7, 14.0, 14.0])
    z = np.zeros_like(x)
    return PathRef.from_targets(TargetStates(x / CAR_SPEED_MPS, x, z, z, speed, z))


def _command(margin_mps: float, speed_mps: float = CAR_SPEED_MPS) -> tuple[float, float]:
    """(throttle, brake) of one speed-loop step with the car at x = 0."""
    config = ControllerConfig(speed_dip_margin_mps=margin_mps)
    controller = Controller(config, CarConfig(), laps=1)
    pose = PoseEstimate(0.0, 0.0, 0.0, 0.0, speed_mps)
    return controller._speed_control(pose, _dipping_path(), speed_mps, 0.02)


def test_off_the_preview_skips_the_dip_and_the_loop_does_not_brake() -> None:
    throttle, brake = _command(0.0)
    assert brake == 0.0 and throttle > 0.0


@pytest.mark.parametrize("margin_mps", [0.5, 1.0])
def test_on_the_loop_brakes_for_the_dip_the_car_is_too_fast_for(margin_mps: float) -> None:
    throttle, brake = _command(margin_mps)
    assert throttle == 0.0 and brake > 0.2


def test_a_car_already_near_the_dip_speed_follows_the_preview_as_before() -> None:
    """The dip is the car's speed within the margin: nothing to correct, same command."""
    assert _command(1.0, 10.2) == _command(0.0, 10.2)
