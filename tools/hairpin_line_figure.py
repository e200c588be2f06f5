"""Draw docs/img/hairpin_line.png: a rules-minimum hairpin seen for the first time, the path
through its gates and the line with the most room for the car's body (planner/exploring_line.py).

    python tools/hairpin_line_figure.py [--out docs/img/hairpin_line.png]
"""

from __future__ import annotations

import argparse
import logging
import math
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from common.car import CarConfig  # noqa: E402
from common.messages import ConeColour  # noqa: E402
from planner.baseframe import SplineBaseframe  # noqa: E402
from planner.config import PlannerConfig  # noqa: E402
from planner.exploration_path import ENTRY_BEHIND_M, exploration_path  # noqa: E402
from planner.exploring_line import steerable_frame  # noqa: E402
from planner.manoeuvres import ManoeuvreGenerator  # noqa: E402
from simulator.hard_tracks import first_arc, hard_track  # noqa: E402

logger = logging.getLogger(__name__)

SEEN_M = 20.0
"""The cones within this (m) of the car are the ones it has seen (the camera's range)."""
EXIT_HEADING_RAD = 2.3
"""Where the body is drawn: the heading (rad) on the way out of the hairpin."""


def _body(x: float, y: float, yaw: float, car: CarConfig) -> np.ndarray:
    """The car's outline (5, 2), its rear axle at (x, y)."""
    front, rear, half = car.length_m - car.rear_overhang_m, -car.rear_overhang_m, car.width_m / 2
    local = np.array([[rear, -half], [front, -half], [front, half], [rear, half], [rear, -half]])
    c, s = math.cos(yaw), math.sin(yaw)
    return np.asarray(local @ np.array([[c, s], [-s, c]]) + (x, y), np.float64)


def draw(out: Path) -> None:
    """Draw the figure into ``out`` (PNG)."""
    config, car = PlannerConfig(), CarConfig()
    limit = ManoeuvreGenerator(config, car).kappa_max_1pm
    track = hard_track("hairpins")
    first, heading, _ = first_arc(track)
    x, y = track.centreline_xy_m[first - 6]  # 3 m before the arc
    seen = np.hypot(track.cones_xy_m[:, 0] - x, track.cones_xy_m[:, 1] - y) < SEEN_M
    cones, colours = track.cones_xy_m[seen], track.colours[seen]
    pts = exploration_path(cones, colours, (x, y), float(heading[first - 6]),
                           track_width_m=config.nominal_track_width_m, behind_m=ENTRY_BEHIND_M)
    gates = SplineBaseframe(pts, False, resample_m=config.baseframe_resample_m,
                            smoothing_m=config.baseframe_smoothing_m,
                            step_m=config.baseframe_step_m,
                            sigma_per_radius=config.smoothing_per_radius)
    line = steerable_frame(gates, cones, colours, (x, y), car, config, limit)
    if line is None:
        raise RuntimeError("no line through the hairpin from this pose")
    fig, ax = plt.subplots(figsize=(7.5, 5.5))
    for colour, style in ((ConeColour.BLUE, "#1f5fd6"), (ConeColour.YELLOW, "#e0b000")):
        m = track.colours == int(colour)
        ax.plot(track.cones_xy_m[m, 0], track.cones_xy_m[m, 1], "o", color=style, ms=6)
    for frame, style, label in ((gates, "--", "path through the gates' middles"),
                                (line, "-", "line with the most room for the body")):
        k = np.abs(frame.curvature_1pm)
        ax.plot(frame.xy_m[:, 0], frame.xy_m[:, 1], style, color="k" if style == "-" else "0.45",
                lw=1.6, label=f"{label} (sharpest {k.max():.2f} 1/m)")
        # the body on the way out of the hairpin, where its front corner swings out most
        i = int(np.argmin(np.abs(np.unwrap(frame.heading_rad) - EXIT_HEADING_RAD)))
        bx, by = frame.xy_m[i]
        body = _body(float(bx), float(by), float(frame.heading_rad[i]), car)
        ax.plot(body[:, 0], body[:, 1], style, color="#c0392b" if style == "-" else "0.6",
                lw=1.2)
    ax.plot(x, y, "s", color="#c0392b", ms=7, label="the car (rear axle)")
    ax.set_xlim(x - 6.0, x + 8.5)
    ax.set_ylim(y - 2.5, y + 11.0)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title("A 9 m hairpin seen for the first time (manoeuvres bend at most "
                 f"{limit:.2f} 1/m)", fontsize=10)
    ax.legend(loc="upper left", fontsize=8)
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=90)
    plt.close(fig)
    logger.info("wrote %s", out)


def main() -> None:
    """Command line: draw the figure."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("docs/img/hairpin_line.png"))
    args = parser.parse_args()
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    draw(args.out)


if __name__ == "__main__":
    main()
