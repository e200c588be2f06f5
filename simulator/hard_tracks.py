"""Hard layouts, one per way a planner fails: ``hard:NAME`` tracks for tests and benchmarks.

Each is built from a list of segments (a straight, or an arc of a given turn and radius) that
turns by half a lap; the list driven twice closes the loop exactly (the second half is the first
turned by 180 degrees), so no closing error has to be smeared over the lap.

- ``hairpins``: two hairpins of the rules' tightest outer diameter (9 m) on a 3 m track,
  joined by 70 m straights;
- ``corner-start``: the same with the start line in the middle of a hairpin;
- ``chicanes``: a chicane on each straight, 3.5 m wide;
- ``straights``: 80 m straights (the rules' longest) into hairpins: braking from top speed;
- ``narrow``: a 3 m track of alternating 90 degree bends;
- ``seam-bend``: the start line in a fast bend, so the lap's seam is where the curvature is.
"""

from __future__ import annotations

import math

import numpy as np

from common.errors import TrackError
from common.polyline import FloatArray
from simulator.track import Track
from simulator.track_generator import track_from_centreline

STEP_M = 0.5
"""Spacing of the centreline samples (m)."""

Segment = tuple[float, float]
"""(turn (rad, positive left; 0 for a straight), radius (m) or length (m) of a straight)."""


def straight(length_m: float) -> Segment:
    """A straight of ``length_m``."""
    return (0.0, length_m)


def arc(turn_rad: float, radius_m: float) -> Segment:
    """An arc turning by ``turn_rad`` (positive left) on ``radius_m``."""
    return (turn_rad, radius_m)


def centreline_from_half(half: list[Segment], step_m: float = STEP_M) -> FloatArray:
    """A closed centreline (M, 2) (no duplicated end point) from segments that turn by pi,
    driven twice. Raises :class:`TrackError` when the half does not turn by pi."""
    turn = sum(t for t, _ in half)
    if abs(turn - math.pi) > 1e-9:
        raise TrackError(f"hard track: a half lap must turn by pi, not {turn:.4f} rad")
    x = y = yaw = 0.0
    pts = [(x, y)]
    for turn_rad, size in half + half:
        length = size if turn_rad == 0.0 else abs(turn_rad) * size
        n = max(int(math.ceil(length / step_m)), 1)
        ds = length / n
        kappa = 0.0 if turn_rad == 0.0 else math.copysign(1.0 / size, turn_rad)
        for _ in range(n):
            # exact integration of an arc (or a straight) over one step
            if kappa == 0.0:
                x += ds * math.cos(yaw)
                y += ds * math.sin(yaw)
            else:
                new_yaw = yaw + kappa * ds
                x += (math.sin(new_yaw) - math.sin(yaw)) / kappa
                y -= (math.cos(new_yaw) - math.cos(yaw)) / kappa
                yaw = new_yaw
            pts.append((x, y))
    centre = np.asarray(pts[:-1], np.float64)
    if math.hypot(x, y) > 1e-6:  # a programming error: the halves must meet
        raise TrackError(f"hard track: the loop does not close ({math.hypot(x, y):.3g} m)")
    return centre


def _index_at(centre: FloatArray, s_m: float) -> int:
    return int(round(s_m / STEP_M)) % len(centre)


HAIRPIN_RADIUS_M = 3.0
"""Centreline radius of the tightest hairpin on a 3 m track: outer diameter 2 (3 + 1.5) = 9 m."""

_LAYOUTS: dict[str, tuple[list[Segment], float, float]] = {
    # name: (half lap, width (m), start line distance along the lap (m))
    "hairpins": ([straight(70.0), arc(math.pi, HAIRPIN_RADIUS_M)], 3.0, 20.0),
    "corner-start": ([straight(70.0), arc(math.pi, HAIRPIN_RADIUS_M)], 3.0,
                     70.0 + 0.5 * math.pi * HAIRPIN_RADIUS_M),
    "chicanes": ([straight(20.0), arc(1.0, 6.0), arc(-2.0, 6.0), arc(1.0, 6.0),
                  straight(20.0), arc(math.pi, 8.0)], 3.5, 10.0),
    "straights": ([straight(80.0), arc(math.pi, 5.0)], 3.5, 10.0),
    "narrow": ([straight(10.0), arc(0.5 * math.pi, 6.0), straight(8.0),
                arc(-0.5 * math.pi, 6.0), straight(8.0), arc(0.5 * math.pi, 6.0),
                straight(10.0), arc(0.5 * math.pi, 6.0)], 3.0, 5.0),
    "seam-bend": ([straight(30.0), arc(0.6 * math.pi, 15.0), straight(15.0),
                   arc(0.4 * math.pi, 9.0)], 3.5, 30.0 + 0.3 * math.pi * 15.0),
}

HARD_LAYOUTS = tuple(_LAYOUTS)
"""The names of the hard layouts (``hard:NAME``)."""


def hard_track(name: str) -> Track:
    """The hard layout ``name`` (see the module docstring) as a trackdrive :class:`Track`."""
    if name not in _LAYOUTS:
        raise TrackError(f"track 'hard:{name}': unknown; hard layouts are "
                         f"{', '.join(HARD_LAYOUTS)}")
    half, width_m, start_s_m = _LAYOUTS[name]
    centre = centreline_from_half(half)
    return track_from_centreline(f"hard:{name}", centre, width_m, _index_at(centre, start_s_m))


def first_arc(track: Track, radius_m: float = HAIRPIN_RADIUS_M
              ) -> tuple[int, FloatArray, FloatArray]:
    """Where ``track``'s first arc of ``radius_m`` begins: the index of its first centreline
    sample bending at least half as much, the centreline's headings (M,) (rad, unwrapped) and
    that arc's centre (2,) (m)."""
    centre = track.centreline_xy_m
    heading = np.unwrap(np.arctan2(np.gradient(centre[:, 1]), np.gradient(centre[:, 0])))
    kappa = np.gradient(heading) / np.hypot(*np.gradient(centre, axis=0).T)
    first = int(np.argmax(np.abs(kappa) > 0.5 / radius_m))
    inside = first + int(round(3.0 / STEP_M))  # well on the arc: its normal meets the centre
    arc_centre = centre[inside] + radius_m * np.sign(kappa[inside]) * np.array(
        [-math.sin(heading[inside]), math.cos(heading[inside])])
    return first, np.asarray(heading, np.float64), np.asarray(arc_centre, np.float64)
