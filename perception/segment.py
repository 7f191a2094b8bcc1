"""Classical segmentation: background difference, shadow rejection, colour split.

Per frame: pixels are labelled floor / ambiguous / object (background.py);
object pixels form connected components; a component holding several
colours (touching objects) is split by per-pixel colour class, with hue-less
pixels (grey objects, metal highlights, dark sides) joined to a touching
coloured segment when they are within a few pixels of it and otherwise kept
as a grey segment of their own.
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage as ndi
from tqdm import tqdm

from perception.background import (
    AMBIGUOUS,
    BRIGHT_OBJECT,
    CHROMA_OBJECT,
    DARK_OBJECT,
    FLOOR,
    FLOOR_RATIO,
    OBJECT,
    Background,
    estimate_background,
)
from perception.types import NEUTRAL, Detection, FrameSegments
from world.types import CLEVR_PALETTE_RGB as PALETTE_RGB, COLORS

CHROMATIC = [c for c in COLORS if c != "gray"]
_PROTOTYPES = np.array([np.asarray(PALETTE_RGB[c], float) / sum(PALETTE_RGB[c]) for c in CHROMATIC])
_PROTOTYPE_LABELS = np.array([COLORS.index(c) for c in CHROMATIC])
_PROTOTYPES = _PROTOTYPES.astype(np.float32)
_PROTOTYPE_NORMS = (_PROTOTYPES ** 2).sum(axis=1)

CANDIDATE_DIFFERENCE = 8  # grey levels: pixels closer than this to the background are floor
MIN_SATURATION = 0.28  # (max - min) / max below which a pixel has no reliable hue
MIN_BRIGHTNESS = 28.0  # max channel below which a pixel's hue is noise
NEUTRAL_REACH = 3  # px: hue-less pixels this close to a coloured segment belong to it
MIN_SEGMENT_AREA = 60  # px: smaller pieces are noise or anti-aliasing fringes


def pixel_hue_labels(rgb: np.ndarray) -> np.ndarray:
    """(P,) colour labels (index into COLORS, or NEUTRAL) of (P, 3) RGB pixels, by nearest palette chromaticity."""
    high = rgb.max(axis=1).astype(np.float32)
    low = rgb.min(axis=1).astype(np.float32)
    hued = (high - low >= MIN_SATURATION * np.maximum(high, 1.0)) & (high >= MIN_BRIGHTNESS)
    labels = np.full(len(rgb), NEUTRAL, dtype=np.int64)
    if hued.any():
        values = rgb[hued].astype(np.float32)
        chroma = values / np.maximum(values.sum(axis=1, keepdims=True), 1.0)
        # nearest prototype: |c - p|^2 = |c|^2 - 2 c.p + |p|^2, and |c|^2 is the same for every p
        labels[hued] = _PROTOTYPE_LABELS[np.argmin(_PROTOTYPE_NORMS - 2.0 * chroma @ _PROTOTYPES.T, axis=1)]
    return labels


def classify_frame(frame: np.ndarray, background: Background, reference: np.ndarray | None = None) -> np.ndarray:
    """(H, W) uint8 FLOOR / AMBIGUOUS / OBJECT labels; only pixels that differ from the background are examined.

    reference: (H, W, 3) int16 background image (background.image.astype(int16)), converted once per video by the caller.
    """
    reference = background.image.astype(np.int16) if reference is None else reference
    candidate = np.zeros(frame.shape[:2], dtype=bool)
    for channel in range(3):  # per channel: avoids a large (H, W, 3) temporary
        difference = frame[..., channel].astype(np.int16) - reference[..., channel]
        candidate |= (difference >= CANDIDATE_DIFFERENCE) | (difference <= -CANDIDATE_DIFFERENCE)
    labels = np.zeros(frame.shape[:2], dtype=np.uint8)
    ys, xs = np.nonzero(candidate)
    if ys.size == 0:
        return labels
    ratio = frame[ys, xs].astype(np.float32) / np.maximum(background.image[ys, xs], 1.0)
    mean = ratio.mean(axis=1)
    chroma = np.abs(ratio - mean[:, None]).max(axis=1) / np.maximum(mean, 0.05)
    label = np.full(ys.shape, AMBIGUOUS, dtype=np.uint8)
    label[(mean >= FLOOR_RATIO) & (chroma < CHROMA_OBJECT)] = FLOOR
    label[(chroma >= CHROMA_OBJECT) | (mean < DARK_OBJECT) | (mean > BRIGHT_OBJECT)] = OBJECT
    labels[ys, xs] = label
    return labels


def segment_frame(frame: np.ndarray, background: Background, frame_index: int = 0,
                  reference: np.ndarray | None = None) -> FrameSegments:
    """Segments of one (H, W, 3) uint8 frame (reference: as classify_frame)."""
    labels = classify_frame(frame, background, reference)
    height, width = labels.shape
    components, count = ndi.label(labels == OBJECT)
    detections: list[Detection] = []
    if count == 0:
        return FrameSegments(frame_index, labels, ())
    slices = ndi.find_objects(components)
    for component_id, window in enumerate(slices, start=1):
        local = components[window] == component_id
        if local.sum() < MIN_SEGMENT_AREA:
            continue
        # Clean per component (cheap on its small window): drop 1-px fringes, fill highlight holes.
        local = ndi.binary_fill_holes(ndi.binary_opening(local, structure=np.ones((2, 2), bool)))
        if local.sum() < MIN_SEGMENT_AREA:
            continue
        top, left = window[0].start, window[1].start
        ly, lx = np.nonzero(local)
        hue = np.full(local.shape, -2, dtype=np.int16)  # -2 outside the component
        hue[ly, lx] = pixel_hue_labels(frame[ly + top, lx + left])
        coloured = hue >= 0
        if coloured.any():
            # Hue-less pixels near a coloured pixel take its label (highlights, dark sides, fringes).
            distance, (iy, ix) = ndi.distance_transform_edt(~coloured, return_indices=True)
            near = (hue == NEUTRAL) & (distance <= NEUTRAL_REACH)
            hue[near] = hue[iy[near], ix[near]]
            # Minor colours inside a component are noise unless they form a sizeable piece.
        for value in np.unique(hue[hue >= NEUTRAL]):
            pieces, piece_count = ndi.label(hue == value)
            for piece in range(1, piece_count + 1):
                py, px = np.nonzero(pieces == piece)
                if py.size < MIN_SEGMENT_AREA:
                    continue
                ys, xs = (py + top).astype(np.int32), (px + left).astype(np.int32)
                touches = bool(ys.min() == 0 or xs.min() == 0 or ys.max() == height - 1 or xs.max() == width - 1)
                detections.append(Detection(frame_index, ys, xs, int(value), touches, component_id))
    return FrameSegments(frame_index, labels, tuple(_absorb_small_neutral(detections, frame, background)))


# Mean brightness, relative to the floor under the piece (the video's own background), above which a
# small hue-less piece is a specular highlight. Relative so that it holds under any light intensity:
# on the default look it is the former fixed 120 grey levels over a floor of about 163.
HIGHLIGHT_BRIGHTNESS = 0.74


def _absorb_small_neutral(detections: list[Detection], frame: np.ndarray, background: Background) -> list[Detection]:
    """Merge small bright hue-less pieces (metal highlights) into the largest coloured segment of their component.

    Dark hue-less pieces are kept: they are the visible part of a grey object touching a coloured one.
    """
    result: list[Detection] = []
    absorbed: dict[int, list[Detection]] = {}
    for det in detections:
        if det.hue_label == NEUTRAL:
            partners = [d for d in detections if d.component == det.component and d.hue_label != NEUTRAL]
            floor = float(background.image[det.ys, det.xs].mean())
            bright = float(frame[det.ys, det.xs].mean()) >= HIGHLIGHT_BRIGHTNESS * floor
            if partners and bright and det.area < 0.35 * max(p.area for p in partners):
                absorbed.setdefault(det.component, []).append(det)
                continue
        result.append(det)
    for k, det in enumerate(result):
        extra = absorbed.get(det.component)
        if not extra or det.hue_label == NEUTRAL:
            continue
        largest = max((d for d in result if d.component == det.component and d.hue_label != NEUTRAL), key=lambda d: d.area)
        if largest is det:
            result[k] = Detection(
                det.frame, np.concatenate([det.ys] + [d.ys for d in extra]), np.concatenate([det.xs] + [d.xs for d in extra]),
                det.hue_label, det.touches_border or any(d.touches_border for d in extra), det.component,
            )
    return result


class ClassicalSegmenter:
    """Background difference + shadow rejection + colour split (no learned weights)."""

    def segment(self, frames: np.ndarray, *, progress: bool = False, background: Background | None = None) -> list[FrameSegments]:
        background = estimate_background(frames) if background is None else background
        iterator = range(frames.shape[0])
        if progress:
            iterator = tqdm(iterator, desc="segment", unit="frame")
        reference = background.image.astype(np.int16)  # once per video, not per frame
        return [segment_frame(frames[f], background, f, reference) for f in iterator]
