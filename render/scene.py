"""Geometry of the pictures: footprints, the top-down view box, events that differ between rollouts.

Pure functions over ``world`` types; no drawing here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from world.camera import footprint_outline
from world.types import Event, Rollout, Shape, World

# Events of two rollouts match when kind and objects agree and frames differ by at most this
# (the same default as check_contact's frame_tolerance).
EVENT_MATCH_FRAMES = 5


def footprint_polygon(shape: Shape, position: np.ndarray, yaw: float) -> np.ndarray:
    """The footprint outline on the plane z = 0, in order around the body.

    position: (3,) metres; yaw: radians. Returns (8, 3) world points (metres).
    """
    outline = footprint_outline(shape, np.asarray(position, dtype=float)[None, :], np.asarray([yaw], dtype=float))
    return outline[0, 1:]  # point 0 is the centre; 1..8 go around the outline


@dataclass(frozen=True)
class TopDownView:
    """A window on the plane (metres, x right, y up) mapped to a ``width`` x ``height`` pixel image (v down)."""

    x_min: float
    x_max: float
    y_min: float
    y_max: float
    width: int
    height: int

    def __post_init__(self) -> None:
        if not (self.x_max > self.x_min and self.y_max > self.y_min):
            raise ValueError(f"TopDownView: empty window x [{self.x_min}, {self.x_max}] y [{self.y_min}, {self.y_max}]")
        if self.width < 2 or self.height < 2:
            raise ValueError(f"TopDownView: image of {self.width}x{self.height} pixels is too small")

    @property
    def pixels_per_metre(self) -> float:
        return min(self.width / (self.x_max - self.x_min), self.height / (self.y_max - self.y_min))

    def to_pixels(self, xy: np.ndarray) -> np.ndarray:
        """(..., 2+) world points (metres; only x, y used) -> (..., 2) pixels, centred in the image."""
        xy = np.asarray(xy, dtype=float)
        scale = self.pixels_per_metre
        cx, cy = (self.x_min + self.x_max) / 2.0, (self.y_min + self.y_max) / 2.0
        u = self.width / 2.0 + (xy[..., 0] - cx) * scale
        v = self.height / 2.0 - (xy[..., 1] - cy) * scale
        return np.stack([u, v], axis=-1)


def view_for(world: World, rollouts: Sequence[Rollout], width: int, height: int, margin: float = 0.3) -> TopDownView:
    """The window holding every active footprint of ``rollouts`` plus ``margin`` metres."""
    radius = max((b.shape.bounding_radius for b in world.bodies), default=0.5)
    points = [r.positions[..., :2][r.active] for r in rollouts if r.active.any()]
    if not points:
        xy = np.array([[b.initial.position[0], b.initial.position[1]] for b in world.bodies] or [[0.0, 0.0]])
    else:
        xy = np.concatenate(points, axis=0)
    pad = radius + margin
    x_min, y_min = xy.min(axis=0) - pad
    x_max, y_max = xy.max(axis=0) + pad
    return TopDownView(float(x_min), float(x_max), float(y_min), float(y_max), int(width), int(height))


def event_key(event: Event) -> tuple[str, tuple[int, ...]]:
    return event.kind, tuple(sorted(int(b) for b in event.bodies))


def diverging_events(
    reference: Sequence[Event], edited: Sequence[Event], tolerance_frames: int = EVENT_MATCH_FRAMES
) -> tuple[tuple[bool, ...], tuple[bool, ...]]:
    """Which events have no counterpart in the other rollout.

    Two events correspond when kind and objects agree and their frames differ by at
    most ``tolerance_frames``; each event is matched at most once (nearest first).
    Returns one flag per event of ``reference`` and of ``edited``: True = diverging.
    """
    used: set[int] = set()
    ref_flags = []
    for event in reference:
        best, best_gap = None, math.inf
        for j, other in enumerate(edited):
            if j in used or event_key(other) != event_key(event):
                continue
            gap = abs(int(other.frame) - int(event.frame))
            if gap <= tolerance_frames and gap < best_gap:
                best, best_gap = j, gap
        if best is not None:
            used.add(best)
        ref_flags.append(best is None)
    return tuple(ref_flags), tuple(j not in used for j in range(len(edited)))
