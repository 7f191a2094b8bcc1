"""Per-track attributes decided over the whole track from its most isolated frames.

* colour: vote of the per-pixel palette labels (segment.pixel_hue_labels),
  the hued pixels' count shared among the hues by squared saturation
  (color_votes); hue-less tracks are grey.
* shape: the primitive (sphere, cube at its best yaw, cylinder) whose
  projected silhouette at the fitted pose overlaps the segments best (lift.py).
* material: P(metal) of a small classifier on appearance statistics pooled
  over the track's frames, trained across looks and renderers
  (perception.material_model; its parameters ship as a JSON file).

Beside each decision, a probability per value (what grounding uses when a
phrase matches no object or several): colour from each hue's share of the
votes (grey's: the hue-less pixels), shape from the mean silhouette
overlap of each primitive, colour and shape each sharpened or softened by one temperature
(COLOR_TEMPERATURE, SHAPE_TEMPERATURE), material from the classifier's
P(metal), whose temperature is part of the shipped model (fitted on
out-of-scene predictions across all its training looks).
"""

from __future__ import annotations

import numpy as np

from perception.background import AMBIGUOUS, FLOOR
from perception.geometry import silhouette_and_top
from perception.lift import Fit
from perception.material_model import appearance_windows, channel_saturation, metal_probability
from perception.segment import pixel_hue_labels
from perception.types import NEUTRAL, Detection, FrameSegments
from world.types import COLORS, MATERIALS, SHAPE_KINDS, Camera

# Temperatures of the attribute probabilities, at minimum mean log loss of the true value over the training sets of
# the material model (MuJoCo tune looks seed 7101 scenes 0-19 and POV-Ray dev seed 7505 scenes 0-11, 206 tracklets
# matched to an object; `python -m bench.train_attributes calibrate`, docs/perception.md "Attribute beliefs").
# Colour: fitted 0.154 on both renderers, the tune-only 0.16 kept (log loss 0.154 tune, 0.290 POV-Ray dev).
AMBIGUOUS_WEIGHT = 0.25  # shadow-like silhouette pixels count this much against a primitive's shape (shape_overlap) ...
HUELESS_AMBIGUOUS_WEIGHT = 0.0  # ... and this much for a grey segment, whose lit faces are shadow-like themselves
COLOR_TEMPERATURE = 0.16  # on pixel shares in [0, 1]
SHAPE_TEMPERATURE = 0.049  # on mean shape overlaps in [0, 1] (shape_overlap; log loss 0.285 tune, 0.545 POV-Ray dev)


def color_votes(detections: list[Detection], frames: np.ndarray) -> np.ndarray:
    """(len(COLORS) + 1,) votes per palette label over the detections' pixels; index 0 = NEUTRAL (no hue), k + 1 = COLORS[k].

    NEUTRAL gets the count of hue-less pixels; the hued pixels' count is shared among the hues in proportion
    to their pixels' squared saturation (material_model.channel_saturation). A pixel mixes the paint with
    white light (a highlight, a metal's reflection) or the floor at an edge; the mix keeps the paint's hue
    but pulls the chromaticity towards grey, where a desaturated red lies nearer brown's than red's: the
    saturated pixels show the paint."""
    counts, saturated = np.zeros(len(COLORS) + 1), np.zeros(len(COLORS) + 1)
    for det in detections:
        rgb = frames[det.frame][det.ys, det.xs]
        labels = pixel_hue_labels(rgb, dark_hues=True) + 1
        high, low = rgb.max(axis=1).astype(np.float32), rgb.min(axis=1).astype(np.float32)
        counts += np.bincount(labels, minlength=len(COLORS) + 1)
        saturated += np.bincount(labels, weights=channel_saturation(high, low) ** 2, minlength=len(COLORS) + 1)
    votes = counts.copy()
    if saturated[1:].sum() > 0:
        votes[1:] = counts[1:].sum() * saturated[1:] / saturated[1:].sum()
    return votes


def color_of(detections: list[Detection], frames: np.ndarray, votes: np.ndarray | None = None) -> str:
    """Colour name by a pixel-weighted vote of the palette labels of the detections' pixels (``votes``: color_votes, if computed)."""
    return color_of_votes(color_votes(detections, frames) if votes is None else votes)


def color_of_votes(votes: np.ndarray) -> str:
    """Colour name from color_votes: the most voted hue, grey when most pixels are hue-less."""
    coloured = votes[1:].copy()
    coloured[COLORS.index("gray")] = 0
    # Grey objects are hue-less; a coloured object has most of its pixels with a hue.
    if votes[0] > coloured.sum():
        return "gray"
    return COLORS[int(np.argmax(coloured))]


def material_of(detections: list[Detection], frames: np.ndarray, segments: list[FrameSegments], color: str,
                shape: str) -> tuple[str, float]:
    """(material, P(metal)) of the material model (perception.material_model) on the detections' frames;
    ``color`` the decided colour (its paint is the reference), ``shape`` a SHAPE_KINDS name."""
    probability = metal_probability(appearance_windows(detections, frames, segments), color, shape)
    return ("metal" if probability > 0.5 else "rubber"), probability


def shape_overlap(camera: Camera, kind: str, fit: Fit, size: float, detection: Detection, labels: np.ndarray,
                  shadow: np.ndarray, free_top: bool = False, cast_shadow: tuple[np.ndarray, int] | None = None) -> float:
    """J_shape = |S & D| / (|D| + |S & floor| + AMBIGUOUS_WEIGHT |S & ambiguous|) of the primitive's silhouette S
    at its fitted pose and the detection D (labels: the frame's (H, W) pixel labels), in [0, 1]; the
    detection's own shadow (``shadow``: segment.own_shadow's (area,) mask) counts as ambiguous, not as D.
    For a grey (hue-less) detection they weigh HUELESS_AMBIGUOUS_WEIGHT (ambiguous_weight): its lit faces are shadow-like.
    With ``free_top`` (lift.fit_primitive's) floor under the primitive's upward surface weighs AMBIGUOUS_WEIGHT:
    it may be the object's top, lit as the floor is, but a larger primitive must not cover the floor for free.

    The fit's own overlap counts shadow-like (ambiguous) pixels neither for nor against, which is right
    for placing a primitive (a grey rubber object is only half certain) but lets a larger primitive win
    the shape decision for free wherever the object stands in its own soft shadow (POV-Ray's area
    lights: cylinders and spheres read as cubes, docs/benchmarks.md "Material across renderers").
    ``cast_shadow`` (lift.shadow_explained: the detection's shadow-like pixels under the fitted primitive's
    shadow, and how many lie outside it) counts those as S & D, the outside ones in |D| too: the body and its
    shadow explain the image, as lift.fit_primitive weighs them (a grey segment holds its deep shadow)."""
    window, sil, top = silhouette_and_top(camera, kind, fit.centre, size, fit.yaw, with_top=free_top)
    if window.empty:
        return 0.0
    region = labels[window.top:window.bottom, window.left:window.right]
    ys, xs = detection.ys - window.top, detection.xs - window.left
    inside = (ys >= 0) & (ys < sil.shape[0]) & (xs >= 0) & (xs < sil.shape[1])
    covered = np.zeros(detection.area, dtype=bool)
    covered[inside] = sil[ys[inside], xs[inside]]
    hits = float((covered & ~shadow).sum())
    explained_outside = 0.0
    if cast_shadow is not None:
        explained, explained_outside = cast_shadow[0], float(cast_shadow[1])
        hits += float((explained & ~covered & ~shadow).sum()) + explained_outside
    floor = float((sil & (region == FLOOR)).sum())
    if top is not None:  # floor that may be the object's top weighs as a shadow-like pixel of a coloured object
        floor -= (1.0 - AMBIGUOUS_WEIGHT) * float((top & (region == FLOOR)).sum())
    ambiguous = float((sil & (region == AMBIGUOUS)).sum()) + float((covered & shadow).sum())
    total = detection.area - float(shadow.sum()) + floor + ambiguous_weight(detection.hue_label == NEUTRAL) * ambiguous + explained_outside
    return hits / total if total > 0 else 0.0  # a segment all shadow: no body to judge


def ambiguous_weight(hueless: bool) -> float:
    """Weight of a shadow-like silhouette pixel against a primitive in the shape overlap (shape_overlap). A
    hue-less object's lit faces are shadow-like themselves (the floor's chroma, darker than the floor): for it
    such a pixel is as likely its body as its shadow."""
    return HUELESS_AMBIGUOUS_WEIGHT if hueless else AMBIGUOUS_WEIGHT


def _softmax(scores: np.ndarray, temperature: float) -> np.ndarray:
    z = scores / temperature
    weights = np.exp(z - z.max())
    return weights / weights.sum()


def color_probabilities(votes: np.ndarray, temperature: float = COLOR_TEMPERATURE) -> dict[str, float]:
    """COLORS name -> p from color_votes: a softmax of each colour's share of the pixels (grey's share: the hue-less pixels)."""
    shares = votes / max(float(votes.sum()), 1.0)
    grey = COLORS.index("gray")
    scores = shares[1:].copy()
    scores[grey] += shares[0]
    return dict(zip(COLORS, (float(p) for p in _softmax(scores, temperature))))


def shape_probabilities(overlaps: dict[str, float], temperature: float = SHAPE_TEMPERATURE) -> dict[str, float]:
    """SHAPE_KINDS name -> p from each primitive's mean silhouette overlap (0..1; a missing kind counts 0)."""
    scores = np.array([overlaps.get(kind, 0.0) for kind in SHAPE_KINDS], dtype=float)
    return dict(zip(SHAPE_KINDS, (float(p) for p in _softmax(scores, temperature))))


def material_probabilities(metal_probability: float, temperature: float = 1.0) -> dict[str, float]:
    """MATERIALS name -> p: P(metal) (already calibrated by the model's own temperature) with its log-odds
    divided by ``temperature``."""
    p = float(np.clip(metal_probability, 1e-9, 1 - 1e-9))
    metal = float(1.0 / (1.0 + np.exp(-np.log(p / (1 - p)) / temperature)))
    return {name: (metal if name == "metal" else 1.0 - metal) for name in MATERIALS}


__all__ = ["ambiguous_weight", "color_of", "color_of_votes", "color_votes", "color_probabilities", "shape_probabilities", "material_probabilities", "material_of", "shape_overlap", "NEUTRAL"]
