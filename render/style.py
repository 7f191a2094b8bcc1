"""Colours and sizes shared by every picture (one owner; the web viewer mirrors COLOR_RGB in viewer.js)."""

from __future__ import annotations

# CLEVRER colour names (world.types.COLORS) -> RGB for drawing.
COLOR_RGB: dict[str, tuple[int, int, int]] = {
    "gray": (150, 150, 150),
    "red": (220, 50, 47),
    "blue": (38, 110, 230),
    "green": (40, 170, 70),
    "brown": (150, 95, 45),
    "yellow": (235, 200, 20),
    "cyan": (30, 200, 210),
    "purple": (150, 70, 200),
}
UNKNOWN_COLOR = (240, 240, 240)
COLLISION_COLOR = (255, 140, 0)
DIVERGING_COLOR = (230, 0, 120)
BACKGROUND = (250, 250, 248)
INK = (30, 30, 30)
GRID = (225, 225, 220)
# How long (s) a collision marker stays drawn around its frame.
MARKER_SECONDS = 0.2
# Velocity arrows show where the body would be this many seconds later.
ARROW_SECONDS = 0.3


def body_rgb(color: str | None) -> tuple[int, int, int]:
    return COLOR_RGB.get(color or "", UNKNOWN_COLOR)
