"""Per-track attributes decided over the whole track from its most isolated frames.

* colour: pixel-count-weighted vote of the per-pixel palette labels
  (segment.pixel_hue_labels); hue-less tracks are grey.
* shape: the primitive (sphere, cube at its best yaw, cylinder) whose
  projected silhouette at the fitted pose overlaps the segments best (lift.py).
* material: metal has a darker body colour with strong, whitish specular
  highlights; rubber is matte. The feature is the ratio of the 98th to the
  50th percentile of the segment's brightness, compared with a per-shape
  threshold measured on the generator's fixture videos (docs/perception.md).
"""

from __future__ import annotations

import numpy as np

from perception.segment import pixel_hue_labels
from perception.types import NEUTRAL, Detection
from world.types import COLORS

# p98/p50 brightness ratio above which an object is metal (per shape; flat
# cube faces and cylinder sides have more shading spread than spheres).
METAL_HIGHLIGHT_RATIO = {"sphere": 1.6, "cylinder": 1.8, "cube": 2.0}


def color_of(detections: list[Detection], frames: np.ndarray) -> str:
    """Colour name by a pixel-weighted vote of the palette labels of the detections' pixels."""
    votes = np.zeros(len(COLORS) + 1)
    for det in detections:
        labels = pixel_hue_labels(frames[det.frame][det.ys, det.xs])
        counts = np.bincount(labels + 1, minlength=len(COLORS) + 1)  # index 0 = NEUTRAL
        votes += counts
    coloured = votes[1:].copy()
    coloured[COLORS.index("gray")] = 0
    # Grey objects are hue-less; a coloured object has most of its pixels with a hue.
    if votes[0] > coloured.sum():
        return "gray"
    return COLORS[int(np.argmax(coloured))]


def highlight_ratio(detections: list[Detection], frames: np.ndarray) -> float:
    """Median over frames of p98/p50 of the segment's brightness (mean of RGB)."""
    ratios = []
    for det in detections:
        lum = frames[det.frame][det.ys, det.xs].astype(np.float32).mean(axis=1)
        ratios.append(np.percentile(lum, 98) / max(np.percentile(lum, 50), 1.0))
    return float(np.median(ratios)) if ratios else 1.0


def material_of(detections: list[Detection], frames: np.ndarray, shape: str) -> tuple[str, float]:
    """(material, highlight ratio)."""
    ratio = highlight_ratio(detections, frames)
    return ("metal" if ratio > METAL_HIGHLIGHT_RATIO[shape] else "rubber"), ratio


__all__ = ["color_of", "highlight_ratio", "material_of", "NEUTRAL"]
