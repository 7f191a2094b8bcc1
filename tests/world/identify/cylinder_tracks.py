"""Tracks of the generator's cylinders as a camera that misses nothing would give them, for identification tests
against MuJoCo runs (bench/pair_mujoco.py)."""

from __future__ import annotations

import numpy as np

from world.observations import ObjectTrack
from world.types import AttributeBelief, Shape

CYLINDER = Shape("cylinder", radius=0.2, half_height=0.2)  # the generator's one size


def cylinder_track(body_id: int, frames: np.ndarray, positions: np.ndarray, material: str = "rubber",
                   attribute_belief: AttributeBelief | None = None) -> ObjectTrack:
    """A red cylinder seen on every one of ``frames`` (T,) at ``positions`` (T, 3) m: yaw unknown, full weight."""
    count = len(frames)
    return ObjectTrack(body_id, CYLINDER, np.asarray(frames), positions, np.full(count, np.nan), np.ones(count, dtype=bool),
                       np.ones(count), color="red", material=material, attribute_belief=attribute_belief)
