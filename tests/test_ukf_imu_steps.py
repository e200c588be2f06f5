"""IMU samples taken together (issue 42, ``mapper.ukf.imu_predict_step_s``): the simulator's
200 Hz IMU propagated in 10 ms steps with the mean input of each pair gives the estimate of one
step per sample (seed 001) to well within its own uncertainty, in half the prediction steps,
and an update between the two samples of a pair meets the state at the update's time."""

from __future__ import annotations

import numpy as np
import pytest

from common.messages import GpsFix, ImuSample, WheelSpeeds
from mapper import ukf_prediction
from mapper.backend import UkfInputs
from mapper.ukf_localiser import UkfLocaliser
from orchestrator.config import AppConfig
from support.drives import drive as simulated


def _run(step_s: float, monkeypatch: pytest.MonkeyPatch
         ) -> tuple[list[tuple[float, np.ndarray, np.ndarray, float]], int]:
    """IMU, wheels (through UkfInputs, as the Mapper feeds them) and GNSS of the default track's
    exploration lap; after each GNSS fix the state, its covariance and its position error to
    the truth (m), and the prediction steps."""
    cfg = AppConfig()
    cfg.mapper.ukf.imu_predict_step_s = step_s
    drive = simulated("default", seed=1)
    ukf = UkfLocaliser(cfg.mapper.ukf, cfg.car)
    inputs = UkfInputs(ukf)
    steps = [0]
    real = ukf_prediction.predict_input

    def counted(*args: object, **kwargs: object) -> None:
        steps[0] += 1
        real(*args, **kwargs)  # type: ignore[arg-type]

    monkeypatch.setattr(ukf_prediction, "predict_input", counted)
    out = []
    for r in drive.readings():
        if isinstance(r, ImuSample):
            ukf.predict(r)
        elif isinstance(r, WheelSpeeds):
            inputs.update_odometry(r, None)
        elif isinstance(r, GpsFix):
            ukf.catch_up(r.timestamp_s)
            if ukf.t_s is None:  # no IMU sample yet
                continue
            # the samples taken together so far were propagated: the state is at the last
            # sample's time, at most one 200 Hz period before the fix
            assert r.timestamp_s - 0.005 - 1e-9 <= ukf.t_s
            ukf.update_gnss_position(drive.frame.geodetic_to_world(r.lat_deg, r.lon_deg))
            x, y, _ = drive.truth.at(ukf.t_s)
            out.append((r.timestamp_s, ukf.x.copy(), ukf.P.copy(),
                        float(np.hypot(ukf.x[0] - x, ukf.x[1] - y))))
    return out, steps[0]


def test_pairs_of_samples_give_the_per_sample_estimate(monkeypatch: pytest.MonkeyPatch) -> None:
    one, one_steps = _run(0.0, monkeypatch)
    pairs, pair_steps = _run(0.01, monkeypatch)
    assert len(one) == len(pairs) > 100
    assert 0.45 * one_steps <= pair_steps <= 0.55 * one_steps
    moved = []
    for (t1, x1, p1, _), (t2, x2, p2, _) in zip(one, pairs, strict=True):
        assert t1 == t2
        sigma_m = np.sqrt(np.trace(p1[:2, :2]) / 2.0)
        moved.append(np.hypot(*(x2[:2] - x1[:2])) / sigma_m)
        # the same uncertainty: the white noise of a pair's mean is half a sample's
        assert np.trace(p2[:2, :2]) == pytest.approx(np.trace(p1[:2, :2]), rel=0.1)
    # what 10 ms steps move is far inside the filter's own sigma (the car accelerates at up to
    # 8 m/s^2 from the start, where the sigma is a few cm)
    assert max(moved) < 0.25 and float(np.median(moved)) < 0.1
    rms = [float(np.sqrt(np.mean([e * e for *_, e in run]))) for run in (one, pairs)]
    assert rms[1] <= 1.02 * rms[0]  # no farther from the truth
