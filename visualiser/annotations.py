"""What makes a frame explain itself: the driven trace coloured by speed with its colour bar,
a legend of every colour drawn, the lap counter with the last and best lap times, and the AS
state in the colour of the car's ASSI lamp.

All drawing is on a pygame Surface in pixels; colours are RGB 0..255.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from functools import lru_cache

import numpy as np
import pygame

TEXT_RGB = (235, 235, 235)
PANEL_RGBA = (0, 0, 0, 160)
SPEED_COLOURMAP = "turbo"
SPEED_STEP_MPS = 5.0
"""The colour bar's top is the fastest speed so far rounded up to this step (m/s)."""

#: The ASSI lamp's colour for each AS state (rules T14.10: yellow ready/driving, blue finished
#: and emergency; flashing is not shown in a still frame).
AS_STATE_RGB: dict[str, tuple[int, int, int]] = {
    "OFF": (120, 120, 120),
    "READY": (255, 215, 0),
    "DRIVING": (255, 215, 0),
    "FINISHED": (40, 110, 255),
    "EMERGENCY": (40, 110, 255),
}


@lru_cache(maxsize=4)
def _lut(name: str = SPEED_COLOURMAP, n: int = 256) -> np.ndarray:
    """The colour map as an (n, 3) uint8 table (matplotlib's)."""
    from matplotlib import colormaps

    table = colormaps[name](np.linspace(0.0, 1.0, n))[:, :3]
    return np.asarray(np.rint(table * 255.0), dtype=np.uint8)


def speed_scale_mps(speeds_mps: np.ndarray) -> float:
    """Top of the speed colour scale (m/s): the fastest finite speed rounded up to 5 m/s."""
    finite = np.asarray(speeds_mps, dtype=float)
    finite = finite[np.isfinite(finite)]
    top = float(finite.max()) if finite.size else 0.0
    return max(SPEED_STEP_MPS, SPEED_STEP_MPS * math.ceil(top / SPEED_STEP_MPS - 1e-9))


def speed_colours(speeds_mps: np.ndarray, top_mps: float) -> np.ndarray:
    """RGB (K, 3) uint8 of speeds (K,) on 0..``top_mps`` (NaN: the scale's bottom)."""
    lut = _lut()
    v = np.nan_to_num(np.asarray(speeds_mps, dtype=float), nan=0.0)
    index = np.clip(np.rint(v / max(top_mps, 1e-9) * (len(lut) - 1)), 0, len(lut) - 1)
    return lut[index.astype(int)]


def draw_speed_trace(surface: pygame.Surface, pixels: np.ndarray, speeds_mps: np.ndarray,
                     top_mps: float, width: int = 2) -> None:
    """The driven trace (K, 2 pixels), each segment in the colour of its speed."""
    if len(pixels) < 2:
        return
    colours = speed_colours(speeds_mps, top_mps).tolist()
    points = pixels.tolist()
    for k in range(1, len(points)):
        pygame.draw.line(surface, colours[k], points[k - 1], points[k], width)


def draw_colour_bar(surface: pygame.Surface, top_mps: float, font: pygame.font.Font) -> None:
    """A vertical speed colour bar on the right edge, labelled in m/s."""
    width, height = surface.get_size()
    bar_h = int(height * 0.4)
    bar_w = max(10, width // 90)
    x0 = width - bar_w - 16 - font.size(f"{top_mps:.0f}")[0]
    y0 = (height - bar_h) // 2
    lut = _lut()
    for row in range(bar_h):
        colour = lut[int(round((1.0 - row / max(bar_h - 1, 1)) * (len(lut) - 1)))].tolist()
        pygame.draw.line(surface, colour, (x0, y0 + row), (x0 + bar_w - 1, y0 + row))
    pygame.draw.rect(surface, TEXT_RGB, (x0, y0, bar_w, bar_h), 1)
    for value in np.linspace(0.0, top_mps, int(round(top_mps / SPEED_STEP_MPS)) + 1):
        y = y0 + int(round((1.0 - value / top_mps) * (bar_h - 1)))
        pygame.draw.line(surface, TEXT_RGB, (x0 + bar_w, y), (x0 + bar_w + 4, y), 1)
        label = font.render(f"{value:.0f}", True, TEXT_RGB)
        surface.blit(label, (x0 + bar_w + 6, y - label.get_height() // 2))
    title = font.render("speed m/s", True, TEXT_RGB)
    surface.blit(title, (min(x0, width - title.get_width() - 4), y0 - title.get_height() - 6))


#: A legend entry: its text and how it is drawn: ("dot" | "ring" | "line" | "box" | "ellipse" |
#: "gradient", RGB).
LegendItem = tuple[str, str, tuple[int, int, int]]


def draw_legend(surface: pygame.Surface, items: Sequence[LegendItem],
                font: pygame.font.Font) -> None:
    """A panel in the bottom-left corner: one swatch and text per entry."""
    if not items:
        return
    line_h = font.get_height() + 3
    swatch_w = 26
    text_w = max(font.size(text)[0] for text, _, _ in items)
    panel_w = swatch_w + text_w + 24
    panel_h = line_h * len(items) + 10
    height = surface.get_height()
    x0, y0 = 6, height - panel_h - 6
    panel = pygame.Surface((panel_w, panel_h), pygame.SRCALPHA)
    panel.fill(PANEL_RGBA)
    surface.blit(panel, (x0, y0))
    lut = _lut()
    for i, (text, kind, rgb) in enumerate(items):
        cy = y0 + 5 + i * line_h + line_h // 2
        sx = x0 + 8
        if kind == "dot":
            pygame.draw.circle(surface, rgb, (sx + swatch_w // 2, cy), 5)
        elif kind == "ring":
            pygame.draw.circle(surface, rgb, (sx + swatch_w // 2, cy), 6, 1)
        elif kind == "line":
            pygame.draw.line(surface, rgb, (sx, cy), (sx + swatch_w, cy), 3)
        elif kind == "thin":
            pygame.draw.line(surface, rgb, (sx, cy), (sx + swatch_w, cy), 1)
        elif kind == "box":
            pygame.draw.rect(surface, rgb, (sx + 3, cy - 5, swatch_w - 6, 10), 2)
        elif kind == "ellipse":
            pygame.draw.ellipse(surface, rgb, (sx + 2, cy - 6, swatch_w - 4, 12), 1)
        elif kind == "gradient":
            for k in range(swatch_w):
                colour = lut[int(k / (swatch_w - 1) * (len(lut) - 1))].tolist()
                pygame.draw.line(surface, colour, (sx + k, cy - 2), (sx + k, cy + 2))
        surface.blit(font.render(text, True, TEXT_RGB),
                     (sx + swatch_w + 8, cy - font.get_height() // 2))


def lap_lines(lap: int, laps_target: int, lap_times_s: Sequence[float]) -> list[str]:
    """``lap 3 / 10`` (laps completed of the mission's), ``last 25.31 s``, ``best 24.90 s``."""
    lines = [f"lap {lap} / {laps_target}" if laps_target > 0 else f"lap {lap}"]
    last = lap_times_s[-1] if lap_times_s else None
    best = min(lap_times_s) if lap_times_s else None
    lines.append(f"last {last:.2f} s" if last is not None else "last  -")
    lines.append(f"best {best:.2f} s" if best is not None else "best  -")
    return lines


def draw_status_panel(surface: pygame.Surface, state: str, lines: Sequence[str],
                      font: pygame.font.Font, big_font: pygame.font.Font) -> None:
    """Top-right: the AS state on its ASSI colour, then the lap lines."""
    width = surface.get_width()
    label = big_font.render(f"AS {state}", True, (0, 0, 0))
    rendered = [font.render(text, True, TEXT_RGB) for text in lines]
    panel_w = max([label.get_width() + 16] + [r.get_width() + 16 for r in rendered])
    panel_h = label.get_height() + 12 + sum(r.get_height() + 3 for r in rendered) + 6
    x0, y0 = width - panel_w - 6, 6
    panel = pygame.Surface((panel_w, panel_h), pygame.SRCALPHA)
    panel.fill(PANEL_RGBA)
    surface.blit(panel, (x0, y0))
    badge = pygame.Rect(x0 + 4, y0 + 4, panel_w - 8, label.get_height() + 4)
    pygame.draw.rect(surface, AS_STATE_RGB.get(state, (200, 200, 200)), badge, border_radius=4)
    surface.blit(label, (badge.centerx - label.get_width() // 2, badge.y + 2))
    y = badge.bottom + 6
    for r in rendered:
        surface.blit(r, (x0 + 8, y))
        y += r.get_height() + 3
