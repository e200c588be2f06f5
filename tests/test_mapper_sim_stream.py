"""Regression: the Mapper on the project simulator's real byte stream (not a synthetic drive).

SimWorld (the scripted exploration driver) -> raw bytes -> SensorManager.ingest (the parsers) ->
Mapper (EKF SLAM backend), with the truth alongside, for the first 18 s of the default track.
Every piece passed its own unit tests while this chain drifted by metres: the simulated IMU has a
per-run gyro bias (sigma 0.002 rad/s) and the car drives off at once (no standstill to calibrate
it), and the rear axle slides outwards in corners (tyre slip). Uncorrected, the gyro bias alone
turns the heading by 0.002 rad/s x 18 s = 0.036 rad and the position error reaches ~0.7 m.

Bounds from the noise: LiDAR cones at 2 cm seen over ~2 s each give the exploration drift of
a SLAM, a few centimetres over this stretch (0.064 m rms, 0.114 m at most, heading 0.0026 rad
at most in this run); the bounds are the exploration-lap acceptance figure (RMSE 0.10 m), twice
the largest error seen, and a heading bound a quarter of the uncorrected gyro drift.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from common.clock import SimClock
from mapper.mapper import Mapper
from orchestrator.config import AppConfig
from sensors.manager import SensorManager
from simulator.driver import ScriptedDriver
from simulator.tracks import load_track
from simulator.world import SimWorld

DURATION_S = 18.0
CONTROL_PERIOD_S = 0.01


@pytest.fixture(scope="module")
def stream_errors() -> dict[str, np.ndarray | float]:
    config = AppConfig()
    track = load_track("default")
    world = SimWorld(config, track, config.sim.seed)
    driver = ScriptedDriver(track, config.car, config.sim.seed,
                            speed_mps=config.sim.driver_speed_mps,
                            steer_noise_rad=config.sim.driver_steer_noise_rad)
    clock = SimClock()
    sensors = SensorManager(config.sensors, config.car, clock)
    mapper = Mapper(config.mapper, config.car)
    pos, yaw = [], []
    for k in range(1, int(round(DURATION_S / CONTROL_PERIOD_S)) + 1):
        t = k * CONTROL_PERIOD_S
        raw = world.step_to(t, driver.command(world.truth(), t))
        clock.set(t)
        sensors.ingest(raw)
        state = mapper.update(sensors.take().readings, t)
        truth = world.truth()
        pose = state.pose
        pos.append(math.hypot(pose.x_m - truth.x_m, pose.y_m - truth.y_m))
        yaw.append(math.remainder(pose.yaw_rad - truth.yaw_rad, 2 * math.pi))
    assert mapper.backend.name == "slam"
    bias = mapper.backend.slam.imu_bias
    return {"pos": np.array(pos), "yaw": np.array(yaw), "gyro_bias": bias[0],
            "landmarks": float(mapper.backend.slam.n_landmarks)}


def test_pose_follows_the_truth_on_the_simulator_stream(stream_errors: dict) -> None:
    pos = stream_errors["pos"]
    rmse = float(np.sqrt(np.mean(pos**2)))
    print(f"pose RMSE {rmse:.3f} m, max {pos.max():.3f} m, "
          f"heading max {np.abs(stream_errors['yaw']).max():.4f} rad")
    assert rmse <= 0.10
    assert pos.max() <= 0.25


def test_heading_does_not_drift_with_the_gyro_bias(stream_errors: dict) -> None:
    assert np.abs(stream_errors["yaw"]).max() <= 0.01


def test_the_gyro_bias_is_estimated(stream_errors: dict) -> None:
    """The simulator's gyro z bias for the default seed is about -0.0018 rad/s (measured against
    the truth); the filter finds it to a few 1e-4 rad/s."""
    assert abs(stream_errors["gyro_bias"] - (-0.0018)) <= 4e-4
    assert stream_errors["landmarks"] > 40
