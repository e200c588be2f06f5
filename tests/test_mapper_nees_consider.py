"""UKF on a map with errors: the map's errors as consider states keep the pose NEES honest.

A map whose cones share one error (the whole map shifted, as a SLAM map drifts as a block) is
seen again sweep after sweep: adding each cone's covariance to every update's noise averages the
shift away and the pose covariance falls below the pose's real error. With the map's joint
covariance as consider states (:meth:`UkfLocaliser.set_map`) the pose covariance keeps it.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from scipy.stats import chi2

from common.messages import ConeMap
from mapper.mapper import Mapper
from orchestrator.config import AppConfig
from support.drives import drive as simulated

SHIFT_SIGMA_M = 0.05
"""The map's common shift per axis (m): far above the LiDAR's 2 cm, so it dominates."""


def _pose_nees(seed: int, joint: bool) -> np.ndarray:
    cfg = AppConfig()
    cfg.mapper.backend = "smoother"
    u = cfg.mapper.ukf
    u.use_gnss_position = False
    u.use_gnss_velocity = False
    drive = simulated("default", seed=seed, seconds=12.0)
    true_map = drive.cone_map()
    n = len(true_map)
    shift = np.random.default_rng(100 + seed).normal(0.0, SHIFT_SIGMA_M, 2)
    cov_each = np.broadcast_to(np.eye(2) * SHIFT_SIGMA_M**2, (n, 2, 2))
    shifted = dataclasses.replace(true_map, xy_m=true_map.xy_m + shift, covariance=cov_each)
    mapper = Mapper(cfg.mapper, cfg.car)
    mapper.freeze(shifted)
    if joint:
        # Every cone carries the same shift: the joint covariance is one block everywhere.
        full = np.kron(np.ones((n, n)), np.eye(2) * SHIFT_SIGMA_M**2)
        mapper.ukf.set_map(shifted, full)
    out = []
    for now, batch in drive.batches():
        if now > 12.0:
            break
        state = mapper.update(batch, now)
        if now > 4.0 and round(now * 100) % 20 == 0:
            p = state.pose
            tx, ty, tyaw = drive.truth.at(p.timestamp_s)
            e = np.array([p.x_m - tx, p.y_m - ty, np.angle(np.exp(1j * (p.yaw_rad - tyaw)))])
            out.append(float(e @ np.linalg.solve(p.covariance, e)))
    assert isinstance(mapper.ukf.consider_map, ConeMap)
    assert mapper.stats["cones"]["applied"] > 100
    return np.array(out)


@pytest.mark.slow
def test_map_errors_as_consider_states_keep_the_pose_nees_in_band() -> None:
    """Pooled over eight drives, the pose NEES (3 dof) with the joint map covariance lies in the
    two-sided 95 % band for >= 90 % of the steps; with the map's cones taken as independent the
    filter is overconfident (mean NEES well above 3). Each drive is one draw of the map's shift,
    which its 40 steps share: one drive's fraction is 0.5 or 1.0, so eight are pooled."""
    lo, hi = chi2.ppf(0.025, 3), chi2.ppf(0.975, 3)
    joint = np.concatenate([_pose_nees(s, True) for s in range(8)])
    inside = float(np.mean((joint >= lo) & (joint <= hi)))
    print(f"joint map covariance: NEES in band {inside:.3f}, mean {joint.mean():.2f}")
    assert inside >= 0.90
    independent = np.concatenate([_pose_nees(s, False) for s in range(8)])
    print(f"independent cones: NEES mean {independent.mean():.2f}")
    assert independent.mean() > 2.0 * joint.mean()
