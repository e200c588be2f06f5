"""Drawing one frame on a pygame Surface (off-screen; no display needed).

Layers, back to front: the true cones (faint, simulation only), the baseframe, candidate
manoeuvres (the chosen one highlighted), waypoints, the driven trace, landmark covariance
ellipses (2 sigma), the map's cones by class with confidence as opacity, the true pose (faint),
the car footprint with its heading and pose ellipse, then the HUD, a scale bar, the speed colour
bar, the AS state with the laps, and the legend (:mod:`visualiser.annotations`).
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence

import numpy as np

os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
import pygame  # noqa: E402

from common.messages import ConeColour  # noqa: E402
from visualiser import annotations as ann  # noqa: E402
from visualiser.annotations import LegendItem  # noqa: E402
from visualiser.frame_data import FrameData, TrackData  # noqa: E402
from visualiser.transform import WorldToPixel  # noqa: E402

BACKGROUND = (28, 30, 34)
CONE_RGB: dict[int, tuple[int, int, int]] = {
    int(ConeColour.UNKNOWN): (200, 200, 200),
    int(ConeColour.BLUE): (40, 110, 255),
    int(ConeColour.YELLOW): (255, 215, 0),
    int(ConeColour.ORANGE): (255, 130, 0),
    int(ConeColour.BIG_ORANGE): (255, 80, 0),
}
CAR_RGB = (230, 40, 60)
TRUTH_RGB = (120, 120, 120)
TRACE_RGB = (230, 40, 60)
BASEFRAME_RGB = (90, 200, 120)
CANDIDATE_RGB = (110, 110, 140)
CHOSEN_RGB = (60, 255, 140)
WAYPOINT_RGB = (170, 120, 255)
TEXT_RGB = (235, 235, 235)

CONE_RADIUS_M = 0.15
CAR_LENGTH_M = 2.9
CAR_WIDTH_M = 1.4
CAR_REAR_OVERHANG_M = 0.65
SIGMA_SCALE = 2.0
_ELLIPSE_STEPS = 16

_font_cache: dict[int, pygame.font.Font] = {}


def _font(size_px: int) -> pygame.font.Font:
    if not pygame.font.get_init():
        pygame.font.init()
    font = _font_cache.get(size_px)
    if font is None:
        font = pygame.font.Font(None, size_px)
        _font_cache[size_px] = font
    return font


def ellipse_points(centres: np.ndarray, covs: np.ndarray, n_sigma: float = SIGMA_SCALE,
                   steps: int = _ELLIPSE_STEPS) -> np.ndarray:
    """Outline points (N, steps, 2) of the n-sigma ellipses of 2x2 covariances (N, 2, 2)."""
    covs = np.asarray(covs, dtype=float).reshape(-1, 2, 2)
    sym = 0.5 * (covs + np.transpose(covs, (0, 2, 1)))
    vals, vecs = np.linalg.eigh(sym)
    radii = n_sigma * np.sqrt(np.clip(vals, 0.0, None))  # (N, 2)
    angles = np.linspace(0.0, 2.0 * math.pi, steps, endpoint=False)
    unit = np.stack([np.cos(angles), np.sin(angles)], axis=1)  # (steps, 2)
    local = unit[None, :, :] * radii[:, None, :]  # (N, steps, 2)
    rotated = np.einsum("nij,nsj->nsi", vecs, local)
    return rotated + np.asarray(centres, dtype=float).reshape(-1, 1, 2)


def car_polygon(x_m: float, y_m: float, yaw_rad: float) -> np.ndarray:
    """The car's footprint corners (4, 2) in the world, vehicle origin at the rear axle."""
    rear = -CAR_REAR_OVERHANG_M
    front = CAR_LENGTH_M - CAR_REAR_OVERHANG_M
    half = 0.5 * CAR_WIDTH_M
    local = np.array([[rear, -half], [front, -half], [front, half], [rear, half]])
    c, s = math.cos(yaw_rad), math.sin(yaw_rad)
    rot = np.array([[c, -s], [s, c]])
    return local @ rot.T + np.array([x_m, y_m])


def _lines(surface: pygame.Surface, colour: tuple[int, ...], pixels: np.ndarray,
           width: int = 1, closed: bool = False) -> None:
    if len(pixels) >= 2:
        pygame.draw.lines(surface, colour, closed, pixels.tolist(), width)


def draw_frame(
    surface: pygame.Surface,
    frame: FrameData,
    view: WorldToPixel,
    track: TrackData | None = None,
    trace_xy_m: np.ndarray | None = None,
    hud_extra: Sequence[str] = (),
    trace_speed_mps: np.ndarray | None = None,
) -> None:
    """Draw ``frame`` on ``surface`` through ``view``; ``trace_speed_mps`` (K,) colours the
    driven trace (K, 2) by speed, with a colour bar."""
    surface.fill(BACKGROUND)
    px_per_m = view.px_per_m
    cone_r = max(3, int(round(CONE_RADIUS_M * px_per_m)))

    if track is not None and len(track.cones_xy_m):
        truth_px = view.to_px(track.cones_xy_m)
        for (u, v), colour in zip(truth_px.tolist(), track.colours.tolist(), strict=True):
            base = CONE_RGB.get(int(colour), CONE_RGB[0])
            faint = tuple(int(0.35 * c + 0.65 * b) for c, b in zip(base, BACKGROUND, strict=True))
            pygame.draw.circle(surface, faint, (u, v), cone_r + 2, 1)

    if len(frame.baseframe_xy_m) >= 2:
        _lines(surface, BASEFRAME_RGB, view.to_px(frame.baseframe_xy_m), 1, closed=True)
    for index, candidate in enumerate(frame.candidates):
        if index != frame.chosen_index and len(candidate) >= 2:
            _lines(surface, CANDIDATE_RGB, view.to_px(candidate), 1)
    if 0 <= frame.chosen_index < len(frame.candidates):
        _lines(surface, CHOSEN_RGB, view.to_px(frame.candidates[frame.chosen_index]), 3)
    for u, v in view.to_px(frame.waypoints_xy_m).tolist():
        pygame.draw.circle(surface, WAYPOINT_RGB, (u, v), 2)
    speed_top_mps = None
    if trace_xy_m is not None and len(trace_xy_m) >= 2:
        if trace_speed_mps is not None and len(trace_speed_mps) == len(trace_xy_m):
            speed_top_mps = ann.speed_scale_mps(trace_speed_mps)
            ann.draw_speed_trace(surface, view.to_px(trace_xy_m), trace_speed_mps,
                                         speed_top_mps)
        else:
            _lines(surface, TRACE_RGB, view.to_px(trace_xy_m), 1)

    n = len(frame.cones_xy_m)
    if n:
        centres_px = np.rint(view.to_px(frame.cones_xy_m)).astype(int)
        outlines = view.to_px(ellipse_points(frame.cones_xy_m, frame.cones_cov))
        overlay = pygame.Surface(surface.get_size(), pygame.SRCALPHA)
        for i in range(n):
            colour = CONE_RGB.get(int(frame.cones_colour[i]), CONE_RGB[0])
            alpha = int(255 * float(frame.cones_conf01[i]))
            if np.ptp(outlines[i], axis=0).max() >= 3.0:
                pygame.draw.polygon(overlay, (*colour, 140), outlines[i].tolist(), 1)
            pygame.draw.circle(overlay, (*colour, alpha), centres_px[i].tolist(), cone_r)
        surface.blit(overlay, (0, 0))

    if frame.truth_pose is not None:
        _lines(surface, TRUTH_RGB, view.to_px(car_polygon(*frame.truth_pose)), 1, closed=True)
    x, y, yaw = frame.pose
    pygame.draw.polygon(surface, CAR_RGB, view.to_px(car_polygon(x, y, yaw)).tolist(), 2)
    tip = view.to_px(np.array([x + 2.5 * math.cos(yaw), y + 2.5 * math.sin(yaw)]))
    pygame.draw.line(surface, CAR_RGB, view.to_px(np.array([x, y])).tolist(), tip.tolist(), 2)
    pose_outline = view.to_px(ellipse_points(np.array([[x, y]]), frame.pose_cov[None])[0])
    _lines(surface, (255, 255, 255), pose_outline, 1, closed=True)

    _draw_hud(surface, frame, hud_extra)
    _draw_scale_bar(surface, px_per_m)
    height = surface.get_height()
    small = _font(max(14, height // 42))
    if speed_top_mps is not None:
        ann.draw_colour_bar(surface, speed_top_mps, small)
    ann.draw_status_panel(
        surface, frame.state,
        ann.lap_lines(frame.lap, frame.laps_target, frame.lap_times_s),
        _font(max(14, height // 36)), _font(max(16, height // 28)))
    ann.draw_legend(surface, legend_items(frame, track is not None,
                                                  speed_top_mps is not None), small)


def legend_items(frame: FrameData, truth: bool, speed_trace: bool) -> list[LegendItem]:
    """The legend of what this frame shows (entries only for what is drawn)."""
    items: list[LegendItem] = [
        ("blue cone (left)", "dot", CONE_RGB[int(ConeColour.BLUE)]),
        ("yellow cone (right)", "dot", CONE_RGB[int(ConeColour.YELLOW)]),
        ("orange cone (start)", "dot", CONE_RGB[int(ConeColour.BIG_ORANGE)]),
        ("cone, colour unknown", "dot", CONE_RGB[int(ConeColour.UNKNOWN)]),
        ("cone 2-sigma ellipse", "ellipse", CONE_RGB[int(ConeColour.UNKNOWN)]),
    ]
    if truth:
        items.append(("true cone (sim)", "ring", TRUTH_RGB))
    items.append(("car estimate, 2-sigma", "box", CAR_RGB))
    if frame.truth_pose is not None:
        items.append(("true car (sim)", "box", TRUTH_RGB))
    if len(frame.baseframe_xy_m) >= 2:
        items.append(("baseframe", "thin", BASEFRAME_RGB))
    if len(frame.candidates) > 1:
        items.append(("candidate manoeuvres", "thin", CANDIDATE_RGB))
    if 0 <= frame.chosen_index < len(frame.candidates):
        items.append(("chosen manoeuvre", "line", CHOSEN_RGB))
    if len(frame.waypoints_xy_m):
        items.append(("waypoints", "dot", WAYPOINT_RGB))
    if speed_trace:
        items.append(("driven trace, by speed", "gradient", TRACE_RGB))
    else:
        items.append(("driven trace", "thin", TRACE_RGB))
    return items


def _draw_hud(surface: pygame.Surface, frame: FrameData, extra: Sequence[str]) -> None:
    height = surface.get_height()
    size = max(14, height // 36)
    font = _font(size)
    lines = [
        f"t {frame.t_s:8.2f} s   state {frame.state}",
        f"speed {frame.speed_mps:5.2f} m/s   target {frame.target_speed_mps:5.2f} m/s",
        f"steer {math.degrees(frame.steering_rad):+6.1f} deg   throttle {frame.throttle:4.2f}"
        f"   brake {frame.brake:4.2f}",
        f"landmarks {len(frame.cones_xy_m)}   loop closed {'yes' if frame.loop_closed else 'no'}",
    ]
    if frame.stale_sources:
        lines.append("STALE: " + ", ".join(frame.stale_sources))
    lines.extend(extra)
    panel = pygame.Surface((int(size * 17.5), (size + 2) * len(lines) + 8), pygame.SRCALPHA)
    panel.fill((0, 0, 0, 150))
    surface.blit(panel, (6, 6))
    for i, text in enumerate(lines):
        surface.blit(font.render(text, True, TEXT_RGB), (12, 10 + i * (size + 2)))


def _draw_scale_bar(surface: pygame.Surface, px_per_m: float) -> None:
    width, height = surface.get_size()
    target_px = width / 8.0
    metres = target_px / px_per_m
    nice = 10 ** math.floor(math.log10(metres))
    for step in (1, 2, 5, 10):
        if nice * step * px_per_m >= target_px * 0.6:
            nice *= step
            break
    bar_px = int(round(nice * px_per_m))
    x0, y0 = width - bar_px - 20, height - 24
    pygame.draw.line(surface, TEXT_RGB, (x0, y0), (x0 + bar_px, y0), 3)
    pygame.draw.line(surface, TEXT_RGB, (x0, y0 - 5), (x0, y0 + 5), 2)
    pygame.draw.line(surface, TEXT_RGB, (x0 + bar_px, y0 - 5), (x0 + bar_px, y0 + 5), 2)
    label = f"{nice:g} m"
    text = _font(max(14, height // 40)).render(label, True, TEXT_RGB)
    surface.blit(text, (x0 + bar_px // 2 - text.get_width() // 2, y0 - 22))
