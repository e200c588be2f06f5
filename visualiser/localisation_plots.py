"""Plots of a localisation-only replay (matplotlib, Agg): the tracks on a map, errors over time.

``localisation_map.png``: the estimate, the reference and the raw GNSS fixes in the
reference's local east-north frame (m), and beside it their offsets to the left of the
reference's direction of travel against the distance along it (a road drive's map is long and
thin: the offsets are what can be seen). ``localisation_error.png``: the horizontal position
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
                             fix_t_s: np.ndarray | None = None,
                             fix_error_m: np.ndarray | None = None,
                             along_m: np.ndarray | None = None,
                             cross_m: np.ndarray | None = None,
                             fix_along_m: np.ndarray | None = None,
                             fix_cross_m: np.ndarray | None = None) -> list[Path]:
    """Write both plots into ``out_dir``; positions (N, 2) east, north (m); ``t_s`` (R,) with
    ``error_m`` and ``course_error_deg`` (R,) at the reference's times; ``fix_t_s`` (F,) with
    ``fix_error_m`` (F,): the raw fixes' errors at their own times; ``along_m``, ``cross_m``
    (R,) and ``fix_along_m``, ``fix_cross_m`` (F,): distance along the reference and offset to
    its left (m) of the estimate and of the fixes."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out_dir.mkdir(parents=True, exist_ok=True)
    written = []
    fig, (ax, ax2) = plt.subplots(1, 2, figsize=(14, 7),
                                  gridspec_kw={"width_ratios": [1, 2]})
    ax.plot(truth_en_m[:, 0], truth_en_m[:, 1], "k-", lw=2.5, alpha=0.5, label="reference")
    if len(fixes_en_m):
        ax.plot(fixes_en_m[:, 0], fixes_en_m[:, 1], ".", color="tab:orange", ms=3,
                label="raw GNSS fixes")
    ax.plot(est_en_m[:, 0], est_en_m[:, 1], "-", color="tab:blue", lw=1.0, label="estimate")
    ax.set_xlabel("east (m)")
    ax.set_ylabel("north (m)")
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(True, alpha=0.3)
    ax.legend()
    ax.set_title("map")
    ax2.axhline(0.0, color="k", lw=2.5, alpha=0.5, label="reference")
    if fix_along_m is not None and fix_cross_m is not None and len(fix_along_m):
        ax2.plot(fix_along_m, fix_cross_m, ".", color="tab:orange", ms=3,
                 label="raw GNSS fixes (as received)")
    if along_m is not None and cross_m is not None:
        ax2.plot(along_m, cross_m, "-", color="tab:blue", lw=1.0, label="estimate")
    ax2.set_xlabel("distance along the reference (m)")
    ax2.set_ylabel("offset to the left of the reference (m)")
    ax2.grid(True, alpha=0.3)
    ax2.legend()
    ax2.set_title("across the road")
    written.append(_save(fig, out_dir / "localisation_map.png"))

    fig, (a1, a2) = plt.subplots(2, 1, figsize=(10, 6), sharex=True)
    if fix_t_s is not None and fix_error_m is not None and len(fix_t_s):
        a1.plot(fix_t_s, fix_error_m, ".", color="tab:orange", ms=2,
                label="raw GNSS fixes (as received)")
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
    top = float(np.percentile(error_m, 99.5)) * 1.2 if len(error_m) else 1.0
    if fix_error_m is not None and len(fix_error_m):
        top = max(top, float(np.percentile(fix_error_m, 99.0)) * 1.1)
    a1.set_ylim(0.0, max(1.0, top))
    written.append(_save(fig, out_dir / "localisation_error.png"))
    return written
