"""What a run keeps for its summary and plots: truth and estimates per tick, laps, stops."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from common.conventions import wrap_angles
from common.messages import GroundTruth, PoseEstimate


@dataclass
class RunLog:
    """Per-tick samples (appended as the run goes; turned into arrays at the end)."""

    t_s: list[float] = field(default_factory=list)
    truth: list[tuple[float, float, float, float]] = field(default_factory=list)
    estimate: list[tuple[float, float, float, float]] = field(default_factory=list)
    position_var_m2: list[float] = field(default_factory=list)
    target_speed_mps: list[float] = field(default_factory=list)
    throttle: list[float] = field(default_factory=list)
    brake: list[float] = field(default_factory=list)
    steering_rad: list[float] = field(default_factory=list)
    covariance: list[np.ndarray] = field(default_factory=list)
    map_frozen: list[bool] = field(default_factory=list)

    def add(self, t_s: float, truth: GroundTruth | None, pose: PoseEstimate,
            target_speed_mps: float, throttle: float, brake: float, steering_rad: float,
            map_frozen: bool = False) -> None:
        self.t_s.append(t_s)
        if truth is not None:
            self.truth.append((truth.x_m, truth.y_m, truth.yaw_rad,
                               math.hypot(truth.vx_mps, truth.vy_mps)))
        self.estimate.append((pose.x_m, pose.y_m, pose.yaw_rad, pose.speed_mps))
        self.position_var_m2.append(float(pose.covariance[0, 0] + pose.covariance[1, 1]))
        self.target_speed_mps.append(target_speed_mps)
        self.throttle.append(throttle)
        self.brake.append(brake)
        self.steering_rad.append(steering_rad)
        self.covariance.append(pose.covariance)
        self.map_frozen.append(map_frozen)

    def arrays(self) -> dict[str, np.ndarray]:
        """Every series as a numpy array; truth and estimate are (T, 4): x, y, yaw, speed."""
        return {
            "t_s": np.asarray(self.t_s),
            "truth": np.asarray(self.truth).reshape(-1, 4),
            "estimate": np.asarray(self.estimate).reshape(-1, 4),
            "position_var_m2": np.asarray(self.position_var_m2),
            "target_speed_mps": np.asarray(self.target_speed_mps),
            "throttle": np.asarray(self.throttle),
            "brake": np.asarray(self.brake),
            "steering_rad": np.asarray(self.steering_rad),
            "covariance": np.asarray(self.covariance).reshape(-1, 3, 3),
            "map_frozen": np.asarray(self.map_frozen, dtype=bool),
        }

    def save(self, path: Path) -> None:
        """Write the arrays as a compressed ``.npz`` (for plots and later analysis)."""
        np.savez_compressed(path, **self.arrays())  # type: ignore[arg-type]

    def pose_errors(self) -> dict[str, float]:
        """Position and heading RMSE over the run and the final position offset (m, rad)."""
        arrays = self.arrays()
        truth, est = arrays["truth"], arrays["estimate"]
        n = min(len(truth), len(est))
        if n == 0:
            return {"pose_rmse_m": math.nan, "heading_rmse_rad": math.nan,
                    "final_offset_m": math.nan}
        d = est[:n, :2] - truth[:n, :2]
        dyaw = wrap_angles(est[:n, 2] - truth[:n, 2])
        return {
            "pose_rmse_m": float(np.sqrt(np.mean(np.sum(d * d, axis=1)))),
            "heading_rmse_rad": float(np.sqrt(np.mean(dyaw * dyaw))),
            "final_offset_m": float(np.hypot(*d[-1])),
        }

    def steering_while_exploring(self, moving_mps: float = 1.0) -> dict[str, float]:
        """How much the commanded steering moved while the car explored (the map not yet
        frozen, the car faster than ``moving_mps``): ``rate_rms_radps``, the RMS of its rate
        (rad/s) over ``seconds`` of such ticks. Plans that jump from one to the next make the
        controller weave, and it shows here; NaN when the car never explored."""
        arrays = self.arrays()
        t, steer, truth = arrays["t_s"], arrays["steering_rad"], arrays["truth"]
        n = min(len(t), len(truth))
        if n < 2:
            return {"rate_rms_radps": math.nan, "seconds": 0.0}
        dt = np.diff(t[:n])
        rate = np.diff(steer[:n]) / np.where(dt > 0.0, dt, np.inf)
        exploring = ~arrays["map_frozen"][1:n] & (truth[1:n, 3] > moving_mps) & (dt > 0.0)
        if not exploring.any():
            return {"rate_rms_radps": math.nan, "seconds": 0.0}
        return {"rate_rms_radps": round(float(np.sqrt(np.mean(rate[exploring] ** 2))), 4),
                "seconds": round(float(np.sum(dt[exploring])), 2)}

    def nees(self) -> dict[str, float | int]:
        """Pose NEES (x, y, yaw; 3 dof) per phase: the fraction of steps inside the two-sided
        95 % chi-square band while mapping (before the map froze) and while localising on the
        frozen map. A consistent filter has about 95 % of its steps inside."""
        from mapper.evaluation import nees, nees_fraction_in_band

        arrays = self.arrays()
        truth, est, cov = arrays["truth"], arrays["estimate"], arrays["covariance"]
        n = min(len(truth), len(est))
        if n == 0:
            return {}
        err = np.column_stack([est[:n, 0] - truth[:n, 0], est[:n, 1] - truth[:n, 1],
                               wrap_angles(est[:n, 2] - truth[:n, 2])])
        cov = cov[:n] + np.eye(3) * 1e-12
        values = nees(err, cov)
        frozen = arrays["map_frozen"][:n]
        # The first second is the filter's own start (pose exactly known): not a test of it.
        settled = arrays["t_s"][:n] >= 1.0
        out: dict[str, float | int] = {"dof": 3}
        for name, sel in (("mapping", settled & ~frozen), ("localising", settled & frozen)):
            if sel.any():
                out[f"{name}_fraction_in_band"] = round(nees_fraction_in_band(values[sel], 3), 4)
                out[f"{name}_mean"] = round(float(np.mean(values[sel])), 3)
                out[f"{name}_steps"] = int(np.count_nonzero(sel))
        return out
