"""The pose carried forward to the control tick: the mapper's estimate is as old as its last
update, and at 15 m/s a pose 0.1 s old puts the car 1.5 m behind where it is.

On the car the map runs in another process (``drive``'s executive) and reaches the control
loop 20-120 ms after it was measured, more on a busy computer (issue 19's ``bench load``: map
age p99 up to 350 ms). The controller steers from where the car *is*: the pose is moved along
its own motion (speed, sideslip and yaw rate, a constant turn) over its age, at most
``max_s``. The covariance grows by the yaw's uncertainty swept over the distance, the
timestamp stays the measurement's (the pose's age is still what it was). A pose from the tick's
own time (the simulator's Main, where the map is updated before control) is returned as it is.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from common.messages import PoseEstimate


def predict_pose(pose: PoseEstimate, now_s: float, max_s: float) -> PoseEstimate:
    """``pose`` moved on to ``now_s`` (s) by its own motion, over at most ``max_s`` (s).

    A constant turn: yaw advances by ``yaw_rate_radps * dt``, the position along the arc of
    the body-frame velocity (``vx_mps``, ``vy_mps``) rotated by the mean yaw. ``dt <= 0``,
    ``max_s <= 0`` or a non-finite motion return ``pose`` itself.
    """
    dt = min(now_s - pose.timestamp_s, max_s)
    if not dt > 0.0:
        return pose
    motion = (pose.vx_mps, pose.vy_mps, pose.yaw_rate_radps, pose.yaw_rad)
    if not all(math.isfinite(v) for v in motion):
        return pose
    dyaw = pose.yaw_rate_radps * dt
    mid = pose.yaw_rad + 0.5 * dyaw
    # the chord of the arc: sin(x)/x of half the turn shortens it (1 when straight)
    half = 0.5 * dyaw
    chord = math.sin(half) / half if abs(half) > 1e-9 else 1.0
    forward, left = pose.vx_mps * dt * chord, pose.vy_mps * dt * chord
    c, s = math.cos(mid), math.sin(mid)
    dx, dy = c * forward - s * left, s * forward + c * left
    cov = np.array(pose.covariance, dtype=np.float64)
    # the yaw's uncertainty swept over the distance moved, across the direction of travel
    var_yaw = max(float(cov[2, 2]), 0.0)
    cross = np.array([-dy, dx])
    cov[:2, :2] += var_yaw * np.outer(cross, cross)
    return dataclasses.replace(pose, x_m=pose.x_m + dx, y_m=pose.y_m + dy,
                               yaw_rad=math.remainder(pose.yaw_rad + dyaw, 2.0 * math.pi),
                               covariance=cov)
