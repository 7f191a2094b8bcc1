"""Data types of the perception stage (no algorithms).

Pixel coordinates: u right, v down, pixel centres at integers. World: metres,
z up, floor z = 0 (as world.types.Camera).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Mapping, Protocol

import numpy as np

from world.types import Camera

# Colour labels of segments: the 8 CLEVRER colours (index into world.types.COLORS).
NEUTRAL = -1  # segment of grey/dark/highlight pixels without a hue


@dataclass(frozen=True, eq=False)
class Detection:
    """One segment (object candidate) in one frame.

    frame: frame index. ys, xs: (P,) int32 pixel rows / columns of the segment.
    hue_label: dominant colour label (index into COLORS, or NEUTRAL).
    touches_border: the segment reaches the image border (object partly out of view).
    component: id of the foreground component it came from (segments of one
    component touch each other).
    """

    frame: int
    ys: np.ndarray
    xs: np.ndarray
    hue_label: int
    touches_border: bool
    component: int
    split: bool = False  # carved out of a segment shared by touching same-coloured objects

    @property
    def area(self) -> int:
        return int(self.ys.size)

    @property
    def centroid(self) -> np.ndarray:
        """(2,) pixel (u, v)."""
        return np.array([self.xs.mean(), self.ys.mean()])


@dataclass(frozen=True)
class FrameSegments:
    """Segments of one frame plus its per-pixel evidence.

    labels: (H, W) uint8 FLOOR / AMBIGUOUS / OBJECT / DEEP (perception.background).
    detections: the object candidates.
    """

    frame: int
    labels: np.ndarray
    detections: tuple[Detection, ...]


@dataclass
class TrackState:
    """A tracked object while tracking runs (mutable working record).

    detections: frame -> Detection assigned to this track (a shared detection
    means the object was merged with another one in that frame).
    """

    id: int
    hue_label: int
    detections: dict[int, Detection] = field(default_factory=dict)
    ground: dict[int, np.ndarray] = field(default_factory=dict)  # frame -> (2,) approx ground xy, m
    merged: set[int] = field(default_factory=set)  # frames where the segment was shared or split
    cut: bool = False  # a piece of a track the tracker cut at a gap (track.MAX_TRACK_GAP)


@dataclass(frozen=True)
class Attributes:
    """A track's decided attributes and, per attribute, a probability for each value
    (perception.attributes.*_probabilities; empty: not computed)."""

    color: str
    shape: str
    material: str
    confidence: float  # 0..1, how clearly the best shape beat the others
    metal_probability: float = 0.5  # P(metal) of the material model (perception.material_model.metal_probability)
    shape_score: float = 0.0  # mean silhouette overlap J of the chosen shape on isolated frames
    color_probabilities: Mapping[str, float] = field(default_factory=dict)  # COLORS name -> p
    shape_probabilities: Mapping[str, float] = field(default_factory=dict)  # SHAPE_KINDS name -> p
    material_probabilities: Mapping[str, float] = field(default_factory=dict)  # MATERIALS name -> p


@dataclass(frozen=True)
class LiftedTrack:
    """A track on the support plane.

    frames: (T,) int64; positions: (T, 3) centre, m; yaw: (T,) rad (NaN unknown);
    visible: (T,) bool centre inside the image; weights: (T,) in [0, 1];
    masks: frame -> (ys, xs) of the fitted silhouette's visible pixels (for scoring/debug).
    """

    id: int
    attributes: Attributes
    frames: np.ndarray
    positions: np.ndarray
    yaw: np.ndarray
    visible: np.ndarray
    weights: np.ndarray


class Segmenter(Protocol):
    """Frames -> per-frame object segments (e.g. a SAM-style model could implement it)."""

    def segment(self, frames: np.ndarray, *, progress: bool = False) -> list[FrameSegments]:
        """frames: (F, H, W, 3) uint8 RGB."""
        ...


class Tracker(Protocol):
    """Per-frame segments -> tracks with persistent anonymous ids."""

    def track(self, segments: list[FrameSegments], camera: Camera) -> list[TrackState]:
        ...


class Lifter(Protocol):
    """Tracks (+ frames for appearance) -> attributes and support-plane poses
    (e.g. a FoundationPose-style model could implement it)."""

    def lift(self, frames: np.ndarray, segments: list[FrameSegments], tracks: list[TrackState],
             camera: Camera, *, progress: bool = False) -> list[LiftedTrack]:
        ...
