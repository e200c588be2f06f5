"""The exploring frame the planner builds through the gates seen, for the planner's tests."""

from __future__ import annotations

import numpy as np

from planner.baseframe import SplineBaseframe
from planner.config import PlannerConfig
from planner.exploration_path import ENTRY_BEHIND_M, exploration_path


def gates_frame(cones: np.ndarray, colours: np.ndarray, x: float, y: float, yaw: float,
                config: PlannerConfig | None = None) -> SplineBaseframe:
    """The exploring frame through the gates of ``cones`` (N, 2) with ``colours`` (N,) seen
    from the car at (x, y) (m) heading ``yaw`` (rad), as the planner builds it."""
    c = config or PlannerConfig()
    pts = exploration_path(cones, colours, (x, y), yaw, track_width_m=c.nominal_track_width_m,
                           behind_m=ENTRY_BEHIND_M)
    return SplineBaseframe(pts, False, resample_m=c.baseframe_resample_m,
                           smoothing_m=c.baseframe_smoothing_m, step_m=c.baseframe_step_m,
                           sigma_per_radius=c.smoothing_per_radius)
