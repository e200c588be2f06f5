"""The run log's steering figure: how much the commanded steering moved while exploring, and
the summary table's row for it."""

from __future__ import annotations

import math

import numpy as np
import pytest

from common.messages import GroundTruth, PoseEstimate
from orchestrator.run_log import RunLog

DT_S = 0.01


def _log(steering: np.ndarray, speed_mps: np.ndarray, frozen: np.ndarray) -> RunLog:
    log = RunLog()
    pose = PoseEstimate(0.0, 0.0, 0.0, 0.0)
    for k, (steer, speed, is_frozen) in enumerate(zip(steering, speed_mps, frozen, strict=True)):
        truth = GroundTruth(k * DT_S, 0.0, 0.0, 0.0, float(speed), 0.0, 0.0)
        log.add(k * DT_S, truth, pose, 0.0, 0.0, 0.0, float(steer), bool(is_frozen))
    return log


def test_the_steering_rate_is_measured_while_exploring_only() -> None:
    # 4 s: standing still with the wheel turning (not exploring), 2 s of a 0.1 rad, 1 Hz weave
    # at 5 m/s while mapping, then 1 s of a 0.3 rad, 2 Hz weave on the frozen map.
    t = np.arange(400) * DT_S
    amplitude = np.where(t < 3.0, 0.1, 0.3)
    frequency_hz = np.where(t < 3.0, 1.0, 2.0)
    steering = amplitude * np.sin(2.0 * math.pi * frequency_hz * t)
    speed = np.where(t < 1.0, 0.0, 5.0)
    frozen = t >= 3.0
    figure = _log(steering, speed, frozen).steering_while_exploring()
    # the RMS of d/dt (A sin(2 pi f t)) over whole periods: A 2 pi f / sqrt(2)
    assert figure["rate_rms_radps"] == pytest.approx(0.1 * 2.0 * math.pi / math.sqrt(2.0),
                                                     rel=0.01)
    assert figure["seconds"] == pytest.approx(2.0, abs=2 * DT_S)


def test_no_exploring_gives_nan() -> None:
    t = np.arange(100) * DT_S
    figure = _log(np.sin(t), np.zeros_like(t), np.zeros_like(t, bool)).steering_while_exploring()
    assert math.isnan(figure["rate_rms_radps"]) and figure["seconds"] == 0.0
    assert math.isnan(RunLog().steering_while_exploring()["rate_rms_radps"])


def test_the_summary_table_shows_the_steering_rate_while_exploring() -> None:
    from orchestrator.summary_table import summary_rows

    rows = dict(summary_rows({"steering_while_exploring": {"rate_rms_radps": 0.7746,
                                                           "seconds": 24.82}}))
    assert rows["steering rate exploring"] == "0.775 rad/s RMS over 24.8 s"
    never = dict(summary_rows({"steering_while_exploring": {"rate_rms_radps": math.nan,
                                                            "seconds": 0.0}}))
    assert "steering rate exploring" not in never
