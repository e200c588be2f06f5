"""Summary plots of a run (matplotlib, no display): trajectory, position error, speed."""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

import numpy as np

log = logging.getLogger(__name__)


def write_summary_plots(
    out_dir: Path, arrays: dict[str, np.ndarray], track: Any = None
) -> list[Path]:
    """Write ``trajectory.png``, ``position_error.png`` and ``speed.png`` into ``out_dir``.

    ``arrays`` holds ``t_s`` (T,), ``truth`` and ``estimate`` (T, 4: x, y, yaw, speed) and
    ``target_speed_mps`` (T,), as :class:`orchestrator.run_log.RunLog` gives them.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out_dir.mkdir(parents=True, exist_ok=True)
    t = arrays["t_s"]
    est = arrays["estimate"]
    truth = arrays.get("truth", np.zeros((0, 4)))
    written: list[Path] = []
    if len(est) == 0:
        return written

    fig, ax = plt.subplots(figsize=(8, 6))
    if track is not None:
        cones = np.asarray(track.cones_xy_m)
        colours = np.asarray(track.colours)
        palette = {0: "grey", 1: "royalblue", 2: "gold", 3: "orange", 4: "orangered"}
        for code, colour in palette.items():
            sel = colours == code
            if sel.any():
                ax.scatter(cones[sel, 0], cones[sel, 1], s=8, c=colour, label=None)
    if len(truth):
        ax.plot(truth[:, 0], truth[:, 1], "k-", lw=1, label="truth")
    ax.plot(est[:, 0], est[:, 1], "r--", lw=1, label="estimate")
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title("Trajectory: estimate against truth")
    ax.legend(loc="best")
    written.append(_save(fig, out_dir / "trajectory.png"))

    if len(truth):
        n = min(len(truth), len(est))
        err = np.hypot(est[:n, 0] - truth[:n, 0], est[:n, 1] - truth[:n, 1])
        fig, ax = plt.subplots(figsize=(8, 4))
        ax.plot(t[:n], err, lw=1)
        ax.set_xlabel("time (s)")
        ax.set_ylabel("position error (m)")
        ax.set_title(f"Position error (RMSE {np.sqrt(np.mean(err**2)):.3f} m)")
        ax.grid(True, alpha=0.3)
        written.append(_save(fig, out_dir / "position_error.png"))

        step = np.hypot(np.diff(truth[:n, 0]), np.diff(truth[:n, 1]))
        distance = np.concatenate([[0.0], np.cumsum(step)])
        fig, ax = plt.subplots(figsize=(8, 4))
        ax.plot(distance, truth[:n, 3], lw=1, label="true speed")
        target = arrays.get("target_speed_mps")
        if target is not None and len(target) >= n:
            ax.plot(distance, target[:n], lw=1, label="planned speed")
        ax.set_xlabel("distance driven (m)")
        ax.set_ylabel("speed (m/s)")
        ax.set_title("Speed over distance against the planned profile")
        ax.legend(loc="best")
        ax.grid(True, alpha=0.3)
        written.append(_save(fig, out_dir / "speed.png"))
    return written


def _save(fig: Any, path: Path) -> Path:
    import matplotlib.pyplot as plt

    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path
