"""The UKF through a stalled serial link (issue 19: a busy machine held the GPS and IMU for
0.46 s at 15.6 m/s; the localisation fell behind and the car hit 16 cones): the pose keeps up
with the car through a gap in the IMU's samples, and the held input widens the covariance so
the cones after the gap still pass the gate."""

from __future__ import annotations

import math

import numpy as np

from common.messages import GpsFix, ImuSample, WheelSpeeds
from mapper.backend import UkfInputs
from mapper.ukf_localiser import UkfLocaliser
from mapper.ukf_state import IVX
from orchestrator.config import AppConfig
from support.drives import drive as simulated

STALL_S = 0.46
"""The stall measured on the loaded machine (the tty worker held both serial links)."""


def _fast_time(seed: int = 1) -> float:
    """A time of the default track's exploration lap at which the car runs at its fastest."""
    tr = simulated("default", seed=seed, gps_bias_sigma_m=0.0).truth
    return float(tr.t_s[int(np.argmax(tr.vx_mps))]) - 0.5


def _run(stall: tuple[float, float] | None, skip_wheels: bool = False,
         probe_s: tuple[float, ...] = ()) -> tuple[UkfLocaliser, dict[float, tuple[float, float]]]:
    """IMU + odometry (through the backend's UkfInputs, as the Mapper feeds them) + GNSS on the
    default track, with the IMU and GNSS samples made in ``stall`` never arriving (they come
    back older than the filter, and the delay buffer drops them); ``skip_wheels`` drops the
    wheels in the stall too. Returns the UKF and, at each ``probe_s``, the first state after
    it: (position error to the truth (m), its 1-sigma along that error (m))."""
    cfg = AppConfig()
    ukf_cfg = cfg.mapper.ukf
    ukf_cfg.gnss_position_sigma_m = 2.5  # the drive's GNSS noise is white 2.5 m: as modelled
    drive = simulated("default", seed=1, gps_bias_sigma_m=0.0)
    ukf = UkfLocaliser(ukf_cfg, cfg.car)
    inputs = UkfInputs(ukf)
    probes = list(probe_s)
    out: dict[float, tuple[float, float]] = {}
    for r in drive.readings():
        t = r.timestamp_s
        in_stall = stall is not None and stall[0] <= t < stall[1]
        if isinstance(r, ImuSample):
            if not in_stall:
                ukf.predict(r)
        elif isinstance(r, WheelSpeeds):
            if not (in_stall and skip_wheels):
                inputs.update_odometry(r, None)
        elif isinstance(r, GpsFix) and not in_stall:
            ukf.catch_up(t)
            ukf.update_gnss_position(drive.frame.geodetic_to_world(r.lat_deg, r.lon_deg))
        if probes and ukf.t_s is not None and ukf.t_s >= probes[0]:
            x, y, _ = drive.truth.at(ukf.t_s)
            e = np.array([ukf.x[0] - x, ukf.x[1] - y])
            norm = float(np.hypot(*e))
            u = e / norm if norm > 0 else np.array([1.0, 0.0])
            out[probes.pop(0)] = (norm, math.sqrt(float(u @ ukf.P[:2, :2] @ u)))
    return ukf, out


def test_wheels_carry_the_pose_through_an_imu_stall() -> None:
    """0.46 s without IMU and GNSS at the lap's top speed (the wheels keep coming, as CAN did):
    the pose is where the car is when the IMU comes back, as near as without the stall (within
    the distance a 0.5 rad/s yaw-rate change turns the car's heading into over the gap:
    v * 0.5 * 0.46^2 / 2 ~ 0.4 m at 8 m/s), inside 3 sigma of its own covariance, and the
    stall is counted as held predictions; without a stall nothing is held."""
    t0 = _fast_time()
    end = t0 + STALL_S
    probes = (end + 0.01, end + 1.0)
    ukf, stalled = _run((t0, end), probe_s=probes)
    clean_ukf, clean = _run(None, probe_s=probes)
    speed = float(np.max(simulated("default", seed=1, gps_bias_sigma_m=0.0).truth.vx_mps))
    allowance_m = speed * 0.5 * STALL_S**2 / 2.0
    for t in probes:
        err, sigma = stalled[t]
        assert err <= clean[t][0] + allowance_m, (t, err, clean[t])
        assert err <= 3.0 * sigma + 0.05, (t, err, sigma)
    assert ukf.stats["imu"]["held"] > 0
    assert "held" not in clean_ukf.stats["imu"]


def test_a_gap_in_the_imu_is_driven_through_not_cut_short() -> None:
    """No IMU, GNSS or wheels for 0.46 s at speed: the first sample after the gap moves the
    pose over the whole gap (before, the step was cut to max_predict_dt_s, 0.05 s: at 8 m/s the
    pose fell 3 m behind the car), and the gap is counted."""
    t0 = _fast_time()
    end = t0 + STALL_S
    ukf, stalled = _run((t0, end), skip_wheels=True, probe_s=(end + 0.01,))
    _, clean = _run(None, probe_s=(end + 0.01,))
    speed = float(np.max(simulated("default", seed=1, gps_bias_sigma_m=0.0).truth.vx_mps))
    err, _ = stalled[end + 0.01]
    assert err <= clean[end + 0.01][0] + speed * 0.5 * STALL_S**2 / 2.0
    assert err < speed * (STALL_S - 0.05) / 4.0  # far from what the cut step left behind
    assert ukf.stats["imu"]["gap"] >= 1


def _diverged_then_standing(reset_after_s: float) -> tuple[UkfLocaliser, list[float]]:
    """A UKF sure the car runs at 7 m/s (sigma 0.014 m/s: what the emulated drive's filter
    believed after a 1.4 s stall of the whole machine, its wheel speeds and IMU samples coming
    back in a burst) while the car stands: 1.5 s of IMU at rest (200 Hz) and wheels at 0
    (100 Hz). Returns the UKF and its speed after each wheel reading."""
    cfg = AppConfig()
    ukf_cfg = cfg.mapper.ukf
    ukf_cfg.static_calibration = False
    ukf_cfg.odometry_reset_after_s = reset_after_s
    ukf = UkfLocaliser(ukf_cfg, cfg.car)
    ukf.x[IVX] = 7.0
    ukf.P[IVX, IVX] = 0.014**2
    speeds: list[float] = []
    for k in range(300):
        t = 10.0 + k * 0.005
        ukf.predict(ImuSample(t, 0.0, 0.0, 9.81, 0.0, 0.0, 0.0))
        if k % 2 == 1:
            ukf.update_odometry(WheelSpeeds(t, 0.0, 0.0, 0.0, 0.0))
            speeds.append(float(ukf.x[IVX]))
    return ukf, speeds


def test_a_filter_that_left_the_wheels_is_reset_to_them() -> None:
    """Wheel speeds gated out without a break for ``odometry_reset_after_s`` (0.5 s): the
    filter, not the wheels, is wrong. Its speed is reset to the wheels' (within 3 of their
    sigmas from then on), once, and its position is widened by what that speed error moved it
    over the 0.5 s (7 m/s x 0.5 s); before it, every reading was rejected. Without the reset
    the filter keeps rejecting the standing car's wheels to the end."""
    ukf, speeds = _diverged_then_standing(0.5)
    odometry = ukf.stats["odometry"]
    assert odometry["reset"] == 1
    # the reading that finds the run 0.5 s long is rejected, then taken after the reset
    kept_out = odometry["rejected"] - 1
    assert 0.5 - 1e-9 <= kept_out * 0.01 < 0.51  # wheel readings every 0.01 s
    assert odometry["applied"] == len(speeds) - kept_out
    sigma = AppConfig().mapper.ukf.odometry_speed_sigma_mps
    assert all(v > 6.0 for v in speeds[:kept_out])
    assert all(abs(v) < 3.0 * sigma for v in speeds[kept_out:])
    assert math.sqrt(ukf.P[0, 0]) > 7.0 * 0.5 * 0.9

    never, never_speeds = _diverged_then_standing(0.0)
    assert "reset" not in never.stats["odometry"]
    assert never.stats["odometry"]["rejected"] == len(never_speeds)
    assert never_speeds[-1] > 6.0
