"""Message types: frozen, validated, read-only arrays."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from common.messages import ActuatorCommand, ConeMap, GpsFix, PoseEstimate


def test_messages_are_frozen() -> None:
    fix = GpsFix(1.0, 49.0, 8.0)
    with pytest.raises(dataclasses.FrozenInstanceError):
        fix.lat_deg = 0.0  # type: ignore[misc]
    assert dataclasses.fields(fix)[0].name == "timestamp_s"


def test_command_rejects_bad_values() -> None:
    ActuatorCommand(0.0, 0.5, 0.0, 0.1)
    with pytest.raises(ValueError, match="not finite"):
        ActuatorCommand(0.0, math.nan, 0.0, 0.0)
    with pytest.raises(ValueError, match="both"):
        ActuatorCommand(0.0, 0.2, 0.2, 0.0)
    with pytest.raises(ValueError, match="outside"):
        ActuatorCommand(0.0, 1.5, 0.0, 0.0)
    stop = ActuatorCommand.full_brake(3.0)
    assert stop.brake == 1.0 and stop.throttle == 0.0


def test_arrays_are_read_only_and_copied() -> None:
    cov = np.eye(3)
    pose = PoseEstimate(0.0, 1.0, 2.0, 0.1, covariance=cov)
    cov[0, 0] = 99.0
    assert pose.covariance[0, 0] == 1.0
    with pytest.raises(ValueError):
        pose.covariance[0, 0] = 5.0
    with pytest.raises(ValueError):
        PoseEstimate(0.0, 0.0, 0.0, 0.0, covariance=np.eye(2))


def test_cone_map_shapes() -> None:
    cones = ConeMap(np.zeros((2, 2)), np.zeros((2, 2, 2)), [1, 2], [1, 1], [1.0, 2.0], [7, 8])
    assert len(cones) == 2 and len(ConeMap.empty()) == 0
    with pytest.raises(ValueError):
        ConeMap(np.zeros((2, 2)), np.zeros((2, 2, 2)), [1], [1, 1], [1.0, 2.0], [7, 8])
