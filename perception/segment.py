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

from perception.background import DEEP, FLOOR, Background, FloorRange, classify_pixels, estimate_background, floor_range, is_foreground, same_chroma
from perception.geometry import primitive_window, ray_depths, window_rays
from perception.lift import fit_primitive, initial_centre
from perception.material_model import appearance_window
from perception.types import NEUTRAL, Detection, FrameSegments
from world.observations import DEFAULT_OBJECT_SIZE
from world.types import CLEVR_PALETTE_RGB as PALETTE_RGB, COLORS, Camera

CHROMATIC = [c for c in COLORS if c != "gray"]
_PROTOTYPES = np.array([np.asarray(PALETTE_RGB[c], float) / sum(PALETTE_RGB[c]) for c in CHROMATIC])
_PROTOTYPE_LABELS = np.array([COLORS.index(c) for c in CHROMATIC])
_PROTOTYPES = _PROTOTYPES.astype(np.float32)
_PROTOTYPE_NORMS = (_PROTOTYPES ** 2).sum(axis=1)

MIN_SATURATION = 0.28  # (max - min) / max below which a pixel has no reliable hue
MIN_BRIGHTNESS = 28.0  # max channel below which a pixel's hue is noise for segmentation ...
# ... and for a whole track's colour, unless its channels spread this much (grey levels): a dark but clearly
# coloured pixel (Blender's dark metal bodies, max channel about 23 with a spread of 20). Dark hue-less pixels
# spread at most 8 (99.9th percentile over grey segments of Blender, MuJoCo and POV-Ray development videos).
# Not for segmentation: there the colour bled into dark contact zones between objects made pieces of its own.
DARK_HUE_SPREAD = 12.0
NEUTRAL_REACH = 3  # px: hue-less pixels this close to a coloured segment belong to it
MIN_SEGMENT_AREA = 60  # px: smaller pieces are noise or anti-aliasing fringes
# A coloured segment's deep pixels (floor chroma, darker than a soft shadow: background.DEEP) are its own contact
# or hard shadow, unless they are most of it (a dark object whose hue is faint).
MAX_OWN_SHADOW = 0.5
FOUR_CONNECTED = ndi.generate_binary_structure(2, 1)  # scipy.ndimage.label's default, built once rather than per call


def pixel_hue_labels(rgb: np.ndarray, dark_hues: bool = False) -> np.ndarray:
    """(P,) colour labels (index into COLORS, or NEUTRAL) of (P, 3) RGB pixels, by nearest palette chromaticity;
    dark_hues: pixels below MIN_BRIGHTNESS keep a hue when they spread DARK_HUE_SPREAD (a track's colour)."""
    red, green, blue = (rgb[:, c].astype(np.float32) for c in range(3))  # per channel: reductions over 3 columns are slow
    high = np.maximum(np.maximum(red, green), blue)
    low = np.minimum(np.minimum(red, green), blue)
    bright_enough = high >= MIN_BRIGHTNESS
    if dark_hues:
        bright_enough |= high - low >= DARK_HUE_SPREAD
    hued = (high - low >= MIN_SATURATION * np.maximum(high, 1.0)) & bright_enough
    labels = np.full(len(rgb), NEUTRAL, dtype=np.int64)
    if hued.any():
        values = np.stack([red[hued], green[hued], blue[hued]], axis=1)
        chroma = values / np.maximum((values[:, 0] + values[:, 1]) + values[:, 2], 1.0)[:, None]
        # nearest prototype: |c - p|^2 = |c|^2 - 2 c.p + |p|^2, and |c|^2 is the same for every p
        labels[hued] = _PROTOTYPE_LABELS[np.argmin(_PROTOTYPE_NORMS - 2.0 * chroma @ _PROTOTYPES.T, axis=1)]
    return labels


def open_2x2(mask: np.ndarray) -> np.ndarray:
    """(h, w) bool: the union of the 2 x 2 pixel blocks lying wholly inside ``mask`` (a morphological opening
    with a 2 x 2 square, as scipy.ndimage.binary_opening with that structure, without its generic machinery)."""
    block = mask[:-1, :-1] & mask[1:, :-1] & mask[:-1, 1:] & mask[1:, 1:]  # top-left corners of whole blocks
    opened = np.zeros_like(mask, dtype=bool)
    for dy in (0, 1):
        for dx in (0, 1):
            opened[dy:dy + block.shape[0], dx:dx + block.shape[1]] |= block
    return opened


def fill_holes(mask: np.ndarray) -> np.ndarray:
    """(h, w) bool ``mask`` with its holes filled: the pieces of its complement (4-connected) that do not reach
    the array's border (as scipy.ndimage.binary_fill_holes, by one labelling instead of repeated dilations)."""
    pieces, count = ndi.label(~mask, structure=FOUR_CONNECTED)
    if count == 0:
        return mask.copy()
    border = np.concatenate([pieces[0], pieces[-1], pieces[:, 0], pieces[:, -1]])
    outside = np.zeros(count + 1, dtype=bool)
    outside[border] = True
    outside[0] = True  # label 0: the mask itself
    return mask | ~outside[pieces]


def own_shadow(labels: np.ndarray, detection: Detection) -> np.ndarray:
    """(area,) bool: the detection's pixels that are its own shadow (MAX_OWN_SHADOW); none for a grey segment,
    whose body is as deep as its shadow."""
    if detection.hue_label == NEUTRAL:
        return np.zeros(detection.area, dtype=bool)
    deep = labels[detection.ys, detection.xs] == DEEP
    return deep if deep.mean() <= MAX_OWN_SHADOW else np.zeros(detection.area, dtype=bool)


def body_of(detection: Detection, shadow: np.ndarray) -> Detection:
    """The detection without its own shadow (``shadow``: own_shadow's (area,) mask)."""
    if not shadow.any():
        return detection
    return Detection(detection.frame, detection.ys[~shadow], detection.xs[~shadow], detection.hue_label,
                     detection.touches_border, detection.component, detection.split)


EDGE_ZONE_PX = 2  # px: the segment's pixels this close to its edge may be mixed object / floor pixels
EDGE_CONTEXT_PX = 3  # px: half-size of the box whose pure object and floor pixels give a mixed pixel's two colours
MIN_EDGE_CONTRAST = 24.0  # grey levels (RGB distance): below this object and floor are too alike to unmix


def sharpen_edges(frame: np.ndarray, labels: np.ndarray, detection: Detection) -> tuple[Detection, np.ndarray]:
    """The detection with its edge pixels that are less than half object taken out, and the frame's labels
    with those pixels made floor: (Detection, (H, W) uint8 labels, a copy when anything changed).

    Blur and compression spread an object's edge over a few pixels; segmentation keeps every pixel that
    differs from the floor by a few grey levels, so a high-contrast object's segment is about a pixel
    larger all round than the object, and a larger primitive's corners cover that ring (cylinders read
    as cubes: docs/perception.md). A pixel within EDGE_ZONE_PX of the edge is modelled as a mix
    alpha x object + (1 - alpha) x floor, its two colours the mean of the pure pixels around it (the
    segment's pixels deeper than the zone, the floor-labelled pixels outside it, within EDGE_CONTEXT_PX);
    alpha is the projection of (pixel - floor) on (object - floor). Both colours are measured in the frame
    itself, so no paint or floor colour is assumed; pixels whose two colours are not known or closer than
    MIN_EDGE_CONTRAST stay. The segment's core is never dropped, so the result is never empty.

    frame: (H, W, 3) uint8; labels: (H, W) uint8 (background labels)."""
    height, width = labels.shape
    margin = EDGE_ZONE_PX + EDGE_CONTEXT_PX + 1
    top, bottom = max(int(detection.ys.min()) - margin, 0), min(int(detection.ys.max()) + margin + 1, height)
    left, right = max(int(detection.xs.min()) - margin, 0), min(int(detection.xs.max()) + margin + 1, width)
    mine = np.zeros((bottom - top, right - left), dtype=bool)
    ys, xs = detection.ys - top, detection.xs - left
    mine[ys, xs] = True
    core = ndi.binary_erosion(mine, iterations=EDGE_ZONE_PX, border_value=1)
    floor = (labels[top:bottom, left:right] == FLOOR) & ~mine
    image = frame[top:bottom, left:right].astype(np.float32)
    size = 2 * EDGE_CONTEXT_PX + 1

    def local_mean(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(h, w, 3) mean colour of the ``mask`` pixels in each pixel's box, and (h, w) bool: the box holds one."""
        count = ndi.uniform_filter(mask.astype(np.float32), size, mode="constant")
        total = ndi.uniform_filter(image * mask[..., None], (size, size, 1), mode="constant")
        return total / np.maximum(count, 1e-6)[..., None], count > 0.5 / size ** 2

    object_colour, has_object = local_mean(core)
    floor_colour, has_floor = local_mean(floor)
    zone = mine & ~core & has_object & has_floor
    contrast = object_colour - floor_colour
    norm2 = (contrast ** 2).sum(axis=-1)
    alpha = ((image - floor_colour) * contrast).sum(axis=-1) / np.maximum(norm2, 1e-6)
    drop = zone & (norm2 >= MIN_EDGE_CONTRAST ** 2) & (alpha < 0.5)
    if not drop.any():
        return detection, labels
    keep = ~drop[ys, xs]
    sharpened = Detection(detection.frame, detection.ys[keep], detection.xs[keep], detection.hue_label,
                          detection.touches_border, detection.component, detection.split)
    relabelled = labels.copy()
    dys, dxs = np.nonzero(drop)
    relabelled[dys + top, dxs + left] = FLOOR
    return sharpened, relabelled


def paint_like_floor(frame: np.ndarray, labels: np.ndarray, detection: Detection) -> bool:
    """Whether the segment's median colour has the chroma of the plain floor around it (the appearance window's
    floor ring; background.same_chroma): a grey object on a grey floor, whose upward faces, lit as the floor is,
    can pass for floor (lift.fit_primitive's free_top). frame (H, W, 3) uint8; labels (H, W) the frame's pixel
    labels. False without floor around it."""
    window = appearance_window(detection, frame, labels)
    if not window.ring.any():
        return False
    paint = np.median(window.rgb[window.segment].astype(np.float32), axis=0)
    floor = np.median(window.rgb[window.ring].astype(np.float32), axis=0)
    return bool(same_chroma(paint / np.maximum(floor, 1.0)))


def classify_frame(frame: np.ndarray, background: Background, bounds: FloorRange | None = None) -> np.ndarray:
    """(H, W) uint8 FLOOR / AMBIGUOUS / OBJECT / DEEP labels (background.classify_pixels; bounds: its floor range,
    computed once per video by the caller)."""
    return classify_pixels(frame, background, bounds)


def segment_frame(frame: np.ndarray, background: Background, frame_index: int = 0,
                  bounds: FloorRange | None = None) -> FrameSegments:
    """Segments of one (H, W, 3) uint8 frame (bounds: as classify_frame)."""
    labels = classify_frame(frame, background, bounds)
    height, width = labels.shape
    components, count = ndi.label(is_foreground(labels), structure=FOUR_CONNECTED)
    detections: list[Detection] = []
    if count == 0:
        return FrameSegments(frame_index, labels, ())
    slices = ndi.find_objects(components)
    areas = np.bincount(components.ravel(), minlength=count + 1)  # one pass: most components are specks
    for component_id, window in enumerate(slices, start=1):
        if areas[component_id] < MIN_SEGMENT_AREA:
            continue
        local = components[window] == component_id
        # Clean per component (cheap on its small window): drop 1-px fringes, fill highlight holes.
        local = fill_holes(open_2x2(local))
        if local.sum() < MIN_SEGMENT_AREA:
            continue
        top, left = window[0].start, window[1].start
        ly, lx = np.nonzero(local)
        hue = np.full(local.shape, -2, dtype=np.int16)  # -2 outside the component
        hue[ly, lx] = pixel_hue_labels(frame[ly + top, lx + left])
        coloured = hue >= 0
        if coloured.any() and (hue == NEUTRAL).any():  # (nothing to join when every pixel has a hue)
            # Hue-less pixels near a coloured pixel take its label (highlights, dark sides, fringes).
            distance, (iy, ix) = ndi.distance_transform_edt(~coloured, return_indices=True)
            near = (hue == NEUTRAL) & (distance <= NEUTRAL_REACH)
            hue[near] = hue[iy[near], ix[near]]
            # Minor colours inside a component are noise unless they form a sizeable piece.
        for value in np.flatnonzero(np.bincount((hue[hue >= NEUTRAL] - NEUTRAL).ravel())) + NEUTRAL:  # the labels present, ascending
            pieces, piece_count = ndi.label(hue == value, structure=FOUR_CONNECTED)
            # pixels of every piece from one pass (not one full-window comparison per piece)
            all_y, all_x = np.nonzero(pieces)
            piece_of = pieces[all_y, all_x]
            order = np.argsort(piece_of, kind="stable")
            bounds = np.cumsum(np.bincount(piece_of, minlength=piece_count + 1))
            for piece in range(1, piece_count + 1):
                members = order[bounds[piece - 1]:bounds[piece]]
                if members.size < MIN_SEGMENT_AREA:
                    continue
                py, px = all_y[members], all_x[members]
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


# One object = one segment. Pieces of one object (a metal body and its highlight read as two palette
# colours, a reflection of the floor or of a neighbour inside a mirror-like object) are merged when
# ONE primitive of the known size, projected with the known camera, explains their union.
PIECE_GAP = 3  # px: pieces closer than this (box to box) are candidates for one object
ONE_OBJECT_AREA = 1.35  # union area / fitted cylinder silhouette area above which it is more than one object
                        # (a cube's top is 4/pi of a disc's; two objects are about 2)
PIECE_COVERAGE = 0.75  # share of each piece's pixels inside the fitted primitive's silhouette
UNION_SEARCH_PX = 4  # px: search radius of the larger piece's fit around its centroid's ray (extended while at the edge)
ENVELOPES = (("cylinder", 0.0), ("cube", 0.0), ("cube", np.pi / 4))  # primitives whose silhouettes may hold a piece


def _union(a: Detection, b: Detection) -> Detection:
    """One detection from two pieces of one object, with the colour label of the larger piece (a grey body
    keeps its label over small tinted reflections; a coloured body over its highlight)."""
    label = a.hue_label if a.area >= b.area else b.hue_label
    return Detection(a.frame, np.concatenate([a.ys, b.ys]), np.concatenate([a.xs, b.xs]), label,
                     a.touches_border or b.touches_border, a.component, a.split or b.split)


def _box(piece: Detection) -> tuple[int, int, int, int]:
    """(left, right, top, bottom) inclusive pixel box."""
    return int(piece.xs.min()), int(piece.xs.max()), int(piece.ys.min()), int(piece.ys.max())


def _near(a: tuple[int, int, int, int], b: tuple[int, int, int, int], gap: int = PIECE_GAP) -> bool:
    """Whether two _box boxes are within ``gap`` px of each other."""
    return not (a[0] > b[1] + gap or b[0] > a[1] + gap or a[2] > b[3] + gap or b[2] > a[3] + gap)


def one_object(camera: Camera, size: float, labels: np.ndarray, a: Detection, b: Detection) -> bool:
    """Whether two nearby pieces are one object: one primitive of half size ``size`` (m) fitted to the larger
    piece holds both (each has >= PIECE_COVERAGE of its pixels inside a cylinder's or cube's silhouette at the
    fitted centre) and their union is no larger than one object's projection (ONE_OBJECT_AREA)."""
    union = _union(a, b)
    reach = primitive_window(camera, "cube", initial_centre(camera, union, size), size, margin=PIECE_GAP)  # widest footprint
    if reach.empty or (union.ys.max() - union.ys.min() >= reach.shape[0] or union.xs.max() - union.xs.min() >= reach.shape[1]):
        return False  # cheap test first: the union does not fit in one object's footprint
    # The primitive is fitted to the larger piece alone (the other piece's pixels count neither for nor against
    # it): the visible part of a second object next to it then falls outside, a piece of the same object inside.
    larger = a if a.area >= b.area else b
    fit = fit_primitive(camera, "cylinder", initial_centre(camera, larger, size), size, 0.0, labels, larger, radii=(UNION_SEARCH_PX,))
    if fit.silhouette_area == 0 or union.area > ONE_OBJECT_AREA * fit.silhouette_area:
        return False
    window = primitive_window(camera, "cube", fit.centre, size)  # holds every envelope's silhouette
    if window.empty:
        return False
    directions = window_rays(camera, window)  # shared by the envelopes' ray casts
    inside = np.zeros(2)
    for kind, yaw in ENVELOPES:
        sil = np.isfinite(ray_depths(camera, kind, fit.centre, size, yaw, window, directions))
        for n, piece in enumerate((a, b)):
            ys, xs = piece.ys - window.top, piece.xs - window.left
            ok = (ys >= 0) & (ys < sil.shape[0]) & (xs >= 0) & (xs < sil.shape[1])
            inside[n] = max(inside[n], float(sil[ys[ok], xs[ok]].sum()) / piece.area)
    return bool(inside.min() >= PIECE_COVERAGE)


def _piece_key(piece: Detection) -> tuple[int, int, int, int]:
    """A piece's pose, coarsely: centroid to 2 px, area to 5 %, colour (a resting object keeps its key)."""
    u, v = piece.centroid
    return int(round(u / 2)), int(round(v / 2)), int(round(np.log(piece.area) / 0.05)), piece.hue_label


def merge_object_pieces(segments: FrameSegments, camera: Camera, size: float = DEFAULT_OBJECT_SIZE,
                        decisions: dict | None = None) -> FrameSegments:
    """The frame's segments with the pieces of one object merged (one_object), largest pieces first.

    decisions: one_object's answers by the pair's coarse poses, shared over a video's frames (most
    objects rest most of the time, so the same pair is judged once).
    """
    decisions = {} if decisions is None else decisions
    detections = sorted(segments.detections, key=lambda d: d.area, reverse=True)
    if len(detections) < 2:
        return segments
    boxes = [_box(d) for d in detections]
    merged_any, k = False, 0
    while k < len(detections):
        for j in range(k + 1, len(detections)):
            if not _near(boxes[k], boxes[j]):
                continue
            key = (_piece_key(detections[k]), _piece_key(detections[j]))
            if key not in decisions:
                decisions[key] = one_object(camera, size, segments.labels, detections[k], detections[j])
            if decisions[key]:
                detections[k] = _union(detections[k], detections.pop(j))
                a, b = boxes[k], boxes.pop(j)
                boxes[k] = (min(a[0], b[0]), max(a[1], b[1]), min(a[2], b[2]), max(a[3], b[3]))
                merged_any = True
                break
        else:
            k += 1  # nothing (more) joins this piece
    if not merged_any:
        return segments
    return FrameSegments(segments.frame, segments.labels, tuple(detections))


class ClassicalSegmenter:
    """Background difference + shadow rejection + colour split (no learned weights); with a camera, the pieces
    of one object are merged into one segment (merge_object_pieces)."""

    def __init__(self, camera: Camera | None = None, object_size: float = DEFAULT_OBJECT_SIZE) -> None:
        self.camera = camera
        self.object_size = object_size

    def segment(self, frames: np.ndarray, *, progress: bool = False, background: Background | None = None) -> list[FrameSegments]:
        background = estimate_background(frames) if background is None else background
        iterator = range(frames.shape[0])
        if progress:
            iterator = tqdm(iterator, desc="segment", unit="frame")
        bounds = floor_range(background)  # once per video, not per frame
        segments = [segment_frame(frames[f], background, f, bounds) for f in iterator]
        if self.camera is None:
            return segments
        decisions: dict = {}
        return [merge_object_pieces(s, self.camera, self.object_size, decisions) for s in segments]
