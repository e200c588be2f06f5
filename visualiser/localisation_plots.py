"""Plots of a localisation-only replay (matplotlib, Agg): the tracks on a map, errors over time.

``localisation_map.png``: the estimate, the reference and the raw GNSS fixes in the
reference's local east-north frame (m). ``localisation_error.png``: the horizontal position
error and the course error against time since the log's start, the GNSS outage shaded.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from visualiser.plots import _save


def write_localisation_plots(out_dir: Path, est_en_m: np.ndarray, truth_en_m: np.ndarray,
                             fixes_en_m: np.ndarray, t_s: np.ndarray, error_m: np.ndarray,
                             course_error_deg: np.ndarray,
                             outage_s: tuple[float, float] | None = None,
                             fix_t_s: np.ndarray | None = None) -> list[Path]:
    """Write both plots into ``out_dir``; positions (N, 2) east, north (m); ``t_s`` (R,) with
    ``error_m`` and ``course_error_deg`` (R,) at the reference's times."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out_dir.mkdir(parents=True, exist_ok=True)
    written = []
    fig, ax = plt.subplots(figsize=(8, 8))
    ax.plot(truth_en_m[:, 0], truth_en_m[:, 1], "k-", lw=2.5, alpha=0.5, label="reference")
    if len(fixes_en_m):
        ax.plot(fixes_en_m[:, 0], fixes_en_m[:, 1], ".", color="tab:orange", ms=3,
                label="raw GNSS fixes")
    ax.plot(est_en_m[:, 0], est_en_m[:, 1], "-", color="tab:blue", lw=1.0, label="estimate")
    ax.set_xlabel("east (m)")
    ax.set_ylabel("north (m)")
    ax.set_aspect("equal")
    ax.grid(True, alpha=0.3)
    ax.legend()
    ax.set_title("localisation: estimate, reference, raw fixes")
    written.append(_save(fig, out_dir / "localisation_map.png"))

    fig, (a1, a2) = plt.subplots(2, 1, figsize=(10, 6), sharex=True)
    a1.plot(t_s, error_m, color="tab:blue", lw=1.0, label="estimate")
    a1.set_ylabel("position error (m)")
    a2.plot(t_s, course_error_deg, color="tab:blue", lw=1.0)
    a2.set_ylabel("course error (deg)")
    a2.set_xlabel("time since the log's start (s)")
    for ax in (a1, a2):
        if outage_s is not None:
            ax.axvspan(outage_s[0], outage_s[1], color="tab:red", alpha=0.15,
                       label="GNSS outage")
        ax.grid(True, alpha=0.3)
    a1.legend()
    a1.set_ylim(0.0, max(1.0, float(np.percentile(error_m, 99.5)) * 1.2) if len(error_m) else 1)
    written.append(_save(fig, out_dir / "localisation_error.png"))
    return written
