"""Per-track attributes decided over the whole track from its most isolated frames.

* colour: pixel-count-weighted vote of the per-pixel palette labels
  (segment.pixel_hue_labels); hue-less tracks are grey.
* shape: the primitive (sphere, cube at its best yaw, cylinder) whose
  projected silhouette at the fitted pose overlaps the segments best (lift.py).
* material: metal reflects light as whitish specular highlights and its body
  is usually darker than its paint; rubber is matte. Three cues that
  calibrate themselves on each video, each the median over the track's
  frames (material_cues): the white light added on top of the paint's own
  chromaticity (90th percentile, relative to the brightness of the floor
  seen around the object in that frame), how desaturated the body is against
  the paint, the body's brightness against the floor and the paint, and the
  peak of the white light against the body's own lit level (no floor in it).
  A logistic rule per shape on them (METAL_WEIGHTS, fitted on the generator's
  ``tune`` looks only; docs/perception.md) says metal or rubber. Spheres have
  their own weights: a sphere always shows its highlight peak, so the peak
  carries weight there; flat cube faces and cylinder sides often show none.

Beside each decision, a probability per value (what grounding uses when a
phrase matches no object or several): colour from the share of the track's
pixels nearest each palette chromaticity, shape from the mean silhouette
overlap of each primitive, material from P(metal) of the rule, each sharpened
or softened by one temperature (COLOR_TEMPERATURE, SHAPE_TEMPERATURE,
MATERIAL_TEMPERATURE) fitted by minimum log loss on the ``tune`` looks only.
"""

from __future__ import annotations

import numpy as np

from scipy import ndimage as ndi

from perception.background import FLOOR
from perception.segment import pixel_hue_labels
from perception.types import NEUTRAL, Detection, FrameSegments, MaterialCues
from world.types import CLEVR_PALETTE_RGB, COLORS, MATERIALS, SHAPE_KINDS

EDGE_PX = 2  # object pixels this close to the segment's edge are left out (they blend with the floor)
FLOOR_RING_PX = (3, 12)  # floor pixels between these distances (px) from the segment give its illumination
MIN_CUE_PIXELS = 20  # fewer interior or floor pixels: the frame gives no material cue
PEAK_FRACTION = 50  # the highlight peak is the mean of the brightest 1/PEAK_FRACTION of the white light (>= 3 pixels)
FLOOR_LEVEL_PERCENTILE = 75  # of the ring's brightness: the lit floor next to the object, above its shadow
GREY_PAINT_RATIO = 0.75  # paint min/max channel ratio above which the paint has no chromaticity to compare with
# Logistic rule per shape, P(metal) = sigmoid(bias + sum w_k cue_k), fitted on the tune looks only
# (physmind synth --looks tune --seed 7101, 24 scenes). Cubes and cylinders: one rule fitted on all
# 172 tracklets (leave-one-scene-out accuracy 0.90); spheres: their own rule on the 50 sphere
# tracklets with 3 or more frames (leave-one-scene-out 48/50).
_FLAT_WEIGHTS = {"specular": 20.43, "desaturation": -2.61, "log_body": -4.77, "peak": 0.0}
METAL_WEIGHTS = {"cube": _FLAT_WEIGHTS, "cylinder": _FLAT_WEIGHTS,
                 "sphere": {"specular": 8.557, "desaturation": 10.107, "log_body": -6.146, "peak": 0.858}}
METAL_BIAS = {"cube": -1.43, "cylinder": -1.43, "sphere": 1.223}
# Temperatures of the attribute probabilities, fitted by minimum log loss on the tune looks only
# (physmind synth --looks tune --seed 7101, 24 scenes, 122 tracks matched to an object; docs/perception.md,
# "Attribute beliefs"). Mean log loss of the true value: colour 0.119, shape 0.248, material 0.155.
COLOR_TEMPERATURE = 0.16  # on pixel shares in [0, 1]
SHAPE_TEMPERATURE = 0.041  # on mean silhouette overlaps in [0, 1]
MATERIAL_TEMPERATURE = 0.52  # divides the rule's log-odds (< 1: the tune looks' rule is surer than it says)


def color_votes(detections: list[Detection], frames: np.ndarray) -> np.ndarray:
    """(len(COLORS) + 1,) pixel counts per palette label over the detections; index 0 = NEUTRAL (no hue), k + 1 = COLORS[k]."""
    votes = np.zeros(len(COLORS) + 1)
    for det in detections:
        labels = pixel_hue_labels(frames[det.frame][det.ys, det.xs])
        votes += np.bincount(labels + 1, minlength=len(COLORS) + 1)
    return votes


def color_of(detections: list[Detection], frames: np.ndarray, votes: np.ndarray | None = None) -> str:
    """Colour name by a pixel-weighted vote of the palette labels of the detections' pixels (``votes``: color_votes, if computed)."""
    votes = color_votes(detections, frames) if votes is None else votes
    coloured = votes[1:].copy()
    coloured[COLORS.index("gray")] = 0
    # Grey objects are hue-less; a coloured object has most of its pixels with a hue.
    if votes[0] > coloured.sum():
        return "gray"
    return COLORS[int(np.argmax(coloured))]


def _interior_and_floor(detection: Detection, labels: np.ndarray) -> tuple[tuple[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]:
    """(rows, cols) of the segment's interior pixels and of the floor ring around it, in a window around the segment."""
    height, width = labels.shape
    reach = FLOOR_RING_PX[1] + 1
    top, left = max(int(detection.ys.min()) - reach, 0), max(int(detection.xs.min()) - reach, 0)
    bottom, right = min(int(detection.ys.max()) + reach + 1, height), min(int(detection.xs.max()) + reach + 1, width)
    mask = np.zeros((bottom - top, right - left), dtype=bool)
    mask[detection.ys - top, detection.xs - left] = True
    interior = ndi.binary_erosion(mask, iterations=EDGE_PX)
    ring = (ndi.binary_dilation(mask, iterations=FLOOR_RING_PX[1]) & ~ndi.binary_dilation(mask, iterations=FLOOR_RING_PX[0])
            & (labels[top:bottom, left:right] == FLOOR))
    iy, ix = np.nonzero(interior)
    ry, rx = np.nonzero(ring)
    return (iy + top, ix + left), (ry + top, rx + left)


def frame_material_cues(pixels: np.ndarray, floor: np.ndarray, color: str) -> tuple[float, float, float, float] | None:
    """(specular, desaturation, log_body, peak) of one frame, or None without enough pixels.

    pixels: (P, 3) uint8 RGB of the object's interior; floor: (Q, 3) of the
    floor around it; color: the object's colour name (its paint is known).
    A pixel is modelled as paint x shading + white light w: then
    w = (min - r max) / (1 - r) with r the paint's min/max channel ratio,
    independent of the shading. specular: 90th percentile of w over the
    floor's lit brightness; desaturation: median min/max ratio minus r;
    log_body: log of the median max channel over floor brightness x paint max;
    peak: log of the mean of the brightest 1/PEAK_FRACTION of w over the body's
    lit level (median max channel over paint max, grey levels).
    Grey paint (r near 1) has no chromaticity: w is the excess over the median brightness.
    """
    if len(pixels) < MIN_CUE_PIXELS or len(floor) < MIN_CUE_PIXELS:
        return None
    paint = np.asarray(CLEVR_PALETTE_RGB[color], dtype=np.float32)
    paint_ratio = float(paint.min() / paint.max())
    rgb = pixels.astype(np.float32)
    high, low = rgb.max(axis=1), rgb.min(axis=1)
    floor_level = max(float(np.percentile(floor.astype(np.float32).max(axis=1), FLOOR_LEVEL_PERCENTILE)), 1.0)
    if paint_ratio < GREY_PAINT_RATIO:
        white = (low - paint_ratio * high) / (1.0 - paint_ratio)
    else:
        white = high - np.median(high)
    white = np.clip(white, 0.0, None)
    specular = float(np.percentile(white, 90)) / floor_level
    desaturation = float(np.percentile(low / np.maximum(high, 1.0), 90)) - paint_ratio
    body_level = float(np.median(high)) / (paint.max() / 255.0)
    log_body = float(np.log(max(body_level / floor_level, 1e-3)))
    top = np.sort(white)[-max(3, len(white) // PEAK_FRACTION):]
    peak = float(np.log(max(float(top.mean()), 1.0) / max(body_level, 1.0)))
    return specular, desaturation, log_body, peak


def material_cues(detections: list[Detection], frames: np.ndarray, segments: list[FrameSegments], color: str) -> MaterialCues:
    """Median of each frame's cues over the detections (frames without enough pixels are skipped)."""
    per_frame = []
    for det in detections:
        (iy, ix), (ry, rx) = _interior_and_floor(det, segments[det.frame].labels)
        cues = frame_material_cues(frames[det.frame][iy, ix], frames[det.frame][ry, rx], color)
        if cues is not None:
            per_frame.append(cues)
    if not per_frame:
        return MaterialCues(specular=0.0, desaturation=0.0, log_body=0.0, peak=0.0, frames=0)
    specular, desaturation, log_body, peak = np.median(np.asarray(per_frame), axis=0)
    return MaterialCues(specular=float(specular), desaturation=float(desaturation), log_body=float(log_body),
                        peak=float(peak), frames=len(per_frame))


def metal_probability(cues: MaterialCues, shape: str) -> float:
    """P(metal) of the shape's logistic rule; 0.5 when no frame gave cues."""
    if cues.frames == 0:
        return 0.5
    z = METAL_BIAS[shape] + sum(weight * getattr(cues, name) for name, weight in METAL_WEIGHTS[shape].items())
    return float(1.0 / (1.0 + np.exp(-z)))


def material_of(detections: list[Detection], frames: np.ndarray, segments: list[FrameSegments], color: str,
                shape: str) -> tuple[str, float]:
    """(material, P(metal)) decided over the detections' frames with the rule of ``shape`` (a SHAPE_KINDS name)."""
    probability = metal_probability(material_cues(detections, frames, segments, color), shape)
    return ("metal" if probability > 0.5 else "rubber"), probability


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


def material_probabilities(metal_probability: float, temperature: float = MATERIAL_TEMPERATURE) -> dict[str, float]:
    """MATERIALS name -> p: the rule's P(metal) with its log-odds divided by the temperature."""
    p = float(np.clip(metal_probability, 1e-9, 1 - 1e-9))
    metal = float(1.0 / (1.0 + np.exp(-np.log(p / (1 - p)) / temperature)))
    return {name: (metal if name == "metal" else 1.0 - metal) for name in MATERIALS}


__all__ = ["color_of", "color_votes", "color_probabilities", "shape_probabilities", "material_probabilities", "material_cues", "material_of", "metal_probability", "NEUTRAL"]
