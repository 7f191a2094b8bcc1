"""Material from appearance statistics pooled over a track, by a small classifier trained across looks.

Per frame, on the object's interior pixels (2 px in from the segment's edge)
and the floor ring around it (3-12 px out, floor-labelled), statistics that
calibrate themselves on the video: brightness and white light relative to the
lit floor next to the object and to the object's own body (highlight peak and
share, dark reflections), the spread and fine detail (Laplacian) of the
shading, the chromaticity spread, saturation from rim to centre, and the
floor's own texture (so that the classifier can discount it). Each is the
median over the track's frames; the frame-to-frame spread of the body's
brightness (moving reflections) is one more. A logistic regression on the
standardised features, with one bias per perceived shape, gives P(metal); its
parameters are a small JSON file in the repository (perception/data/
material_model.json), trained by ``python -m bench.train_attributes`` on many
appearance settings at once (MuJoCo ``tune`` and ``default`` looks, POV-Ray
renders; never the evaluation seeds) and evaluated leave-one-renderer-out
(docs/benchmarks.md, "Material across renderers").
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np
from scipy import ndimage as ndi

from perception.background import FLOOR
from perception.types import Detection, FrameSegments
from world.types import CLEVR_PALETTE_RGB, SHAPE_KINDS

EDGE_PX = 2  # object pixels this close to the segment's edge are left out (they blend with the floor)
FLOOR_RING_PX = (3, 12)  # floor pixels between these distances (px) from the segment give its illumination
MIN_CUE_PIXELS = 20  # fewer interior or floor pixels: the frame gives no cue
FLOOR_LEVEL_PERCENTILE = 75  # of the ring's brightness: the lit floor next to the object, above its shadow
GREY_PAINT_RATIO = 0.75  # paint min/max channel ratio above which the paint has no chromaticity to compare with
PEAK_FRACTION = 50  # the highlight peak: mean of the brightest 1/PEAK_FRACTION of the white light (>= 3 pixels)
MODEL_PATH = Path(__file__).with_name("data") / "material_model.json"

FRAME_FEATURES = ("specular", "desaturation", "log_body", "peak", "log_high", "log_low", "bright_share",
                  "detail", "chroma_spread", "rim_saturation", "spread", "floor_texture", "log_raw_body")
TRACK_FEATURES = FRAME_FEATURES + ("flicker",)


def channel_saturation(high: np.ndarray, low: np.ndarray) -> np.ndarray:
    """(P,) saturation in [0, 1] of pixels from their brightest and dimmest channel (grey levels): 1 - low / high
    (0 grey, 1 a pure hue)."""
    return 1.0 - low / np.maximum(high, 1.0)


@dataclass(frozen=True)
class AppearanceWindow:
    """One frame's pixels around a segment: rgb (h, w, 3) uint8; interior, ring, segment: (h, w) bool masks
    (the segment's pixels EDGE_PX in from its edge, the floor ring around it, the whole segment)."""

    rgb: np.ndarray
    interior: np.ndarray
    ring: np.ndarray
    segment: np.ndarray

    def __post_init__(self):
        if self.rgb.ndim != 3 or self.rgb.shape[2] != 3 or self.rgb.dtype != np.uint8:
            raise ValueError(f"rgb: expected (h, w, 3) uint8, got {self.rgb.shape} {self.rgb.dtype}")
        for name in ("interior", "ring", "segment"):
            mask = getattr(self, name)
            if mask.shape != self.rgb.shape[:2] or mask.dtype != bool:
                raise ValueError(f"{name}: expected {self.rgb.shape[:2]} bool, got {mask.shape} {mask.dtype}")


def appearance_window(detection: Detection, frame: np.ndarray, labels: np.ndarray) -> AppearanceWindow:
    """The window of one detection: frame (H, W, 3) uint8, labels (H, W) the segmenter's pixel labels."""
    height, width = labels.shape
    reach = FLOOR_RING_PX[1] + 1
    top, left = max(int(detection.ys.min()) - reach, 0), max(int(detection.xs.min()) - reach, 0)
    bottom, right = min(int(detection.ys.max()) + reach + 1, height), min(int(detection.xs.max()) + reach + 1, width)
    segment = np.zeros((bottom - top, right - left), dtype=bool)
    segment[detection.ys - top, detection.xs - left] = True
    interior = ndi.binary_erosion(segment, iterations=EDGE_PX)
    ring = (ndi.binary_dilation(segment, iterations=FLOOR_RING_PX[1]) & ~ndi.binary_dilation(segment, iterations=FLOOR_RING_PX[0])
            & (labels[top:bottom, left:right] == FLOOR))
    return AppearanceWindow(np.ascontiguousarray(frame[top:bottom, left:right]), interior, ring, segment)


def appearance_windows(detections: list[Detection], frames: np.ndarray, segments: list[FrameSegments]) -> list[AppearanceWindow]:
    """appearance_window of each detection (frames (F, H, W, 3) uint8)."""
    return [appearance_window(det, frames[det.frame], segments[det.frame].labels) for det in detections]


def frame_features(window: AppearanceWindow, color: str) -> np.ndarray | None:
    """(len(FRAME_FEATURES),) statistics of one frame, or None without enough interior or floor pixels.

    A pixel is modelled as paint x shading + white light w: w = (min - r max) / (1 - r) with r the
    paint's min/max channel ratio (grey paint: the excess over the median brightness). Brightness is
    the max channel; ``floor`` the 75th percentile of the ring's brightness (the lit floor).
    """
    pixels = window.rgb[window.interior].astype(np.float32)
    floor_pixels = window.rgb[window.ring].astype(np.float32)
    if len(pixels) < MIN_CUE_PIXELS or len(floor_pixels) < MIN_CUE_PIXELS:
        return None
    paint = np.asarray(CLEVR_PALETTE_RGB[color], dtype=np.float32)
    paint_ratio = float(paint.min() / paint.max())
    high, low = pixels.max(axis=1), pixels.min(axis=1)
    floor_bright = floor_pixels.max(axis=1)
    floor_level = max(float(np.percentile(floor_bright, FLOOR_LEVEL_PERCENTILE)), 1.0)
    median_high = max(float(np.median(high)), 1.0)
    if paint_ratio < GREY_PAINT_RATIO:
        white = (low - paint_ratio * high) / (1.0 - paint_ratio)
    else:
        white = high - median_high
    white = np.clip(white, 0.0, None)
    body_level = median_high / (paint.max() / 255.0)
    top = np.sort(white)[-max(3, len(white) // PEAK_FRACTION):]
    saturation = channel_saturation(high, low)
    # fine detail of the shading: mirror-like surfaces show the scene, matte ones a smooth gradient
    grey = window.rgb.astype(np.float32).mean(axis=2)
    detail = float(np.mean(np.abs(ndi.laplace(ndi.gaussian_filter(grey, 0.7)))[window.interior])) / median_high
    # saturation from rim to centre: distance from the segment's edge splits the interior in halves
    depth = ndi.distance_transform_edt(window.segment)[window.interior]
    inner = depth >= np.median(depth)
    rim_saturation = (float(np.median(saturation[inner])) + 0.02) / (float(np.median(saturation[~inner])) + 0.02) if (~inner).any() else 1.0
    chroma = pixels / np.maximum(pixels.sum(axis=1, keepdims=True), 1.0)
    return np.array([
        float(np.percentile(white, 90)) / floor_level,  # specular
        float(np.percentile(low / np.maximum(high, 1.0), 90)) - paint_ratio,  # desaturation
        float(np.log(max(body_level / floor_level, 1e-3))),  # log_body
        float(np.log(max(float(top.mean()), 1.0) / max(body_level, 1.0))),  # peak
        float(np.log(max(float(np.percentile(high, 99)), 1.0) / median_high)),  # log_high
        float(np.log(max(float(np.percentile(high, 10)), 1.0) / median_high)),  # log_low
        float(np.mean(high > floor_level)),  # bright_share
        detail,
        float(chroma.std(axis=0).sum()),  # chroma_spread
        float(np.log(rim_saturation)),
        float(np.percentile(high, 90) - np.percentile(high, 10)) / median_high,  # spread
        float(np.log(max(float(np.percentile(floor_bright, 90)), 1.0) / max(float(np.percentile(floor_bright, 10)), 1.0))),  # floor_texture
        float(np.log(median_high / floor_level)),  # log_raw_body
    ])


def track_features(windows: list[AppearanceWindow], color: str) -> np.ndarray | None:
    """(len(TRACK_FEATURES),) per-frame features pooled over a track (medians; flicker = the std of log_raw_body
    over frames), or None when no frame gives features."""
    rows = [f for f in (frame_features(w, color) for w in windows) if f is not None]
    if not rows:
        return None
    table = np.asarray(rows)
    flicker = float(table[:, FRAME_FEATURES.index("log_raw_body")].std()) if len(rows) > 1 else 0.0
    return np.concatenate([np.median(table, axis=0), [flicker]])


def shape_one_hot(shape: str) -> np.ndarray:
    """(len(SHAPE_KINDS),) float 1 at the perceived shape's kind: the trees' shape inputs."""
    return np.array([float(shape == kind) for kind in SHAPE_KINDS])


@dataclass(frozen=True)
class TreeEnsemble:
    """Boosted regression trees (bench.train_attributes: scikit-learn's HistGradientBoostingClassifier, exported):
    raw log-odds = baseline + the sum over trees of the leaf each input reaches. Nodes of all trees in flat
    (nodes,) arrays: ``feature`` (int, -1 at a leaf), ``threshold`` (go left when x[feature] <= threshold),
    ``missing_left`` (where a NaN goes), ``left`` / ``right`` (node indices), ``value`` (a leaf's log-odds
    term); ``roots`` (trees,) the index of each tree's first node."""

    baseline: float
    feature: np.ndarray
    threshold: np.ndarray
    missing_left: np.ndarray
    left: np.ndarray
    right: np.ndarray
    value: np.ndarray
    roots: np.ndarray

    def __post_init__(self):
        nodes = self.feature.shape
        for name in ("threshold", "missing_left", "left", "right", "value"):
            if getattr(self, name).shape != nodes:
                raise ValueError(f"material model trees: {name} expected {nodes}, got {getattr(self, name).shape}")
        inner = self.feature >= 0
        if np.any(self.left[inner] >= nodes[0]) or np.any(self.right[inner] >= nodes[0]) or np.any(self.roots >= nodes[0]):
            raise ValueError("material model trees: a node index points past the nodes")

    def raw(self, x: np.ndarray) -> float:
        """Log-odds of one (inputs,) vector."""
        total = self.baseline
        for node in self.roots:
            while self.feature[node] >= 0:
                value = x[self.feature[node]]
                go_left = self.missing_left[node] if np.isnan(value) else value <= self.threshold[node]
                node = self.left[node] if go_left else self.right[node]
            total += self.value[node]
        return float(total)

    def to_json(self) -> dict:
        return {"baseline": self.baseline, "feature": self.feature.tolist(), "threshold": self.threshold.tolist(),
                "missing_left": self.missing_left.tolist(), "left": self.left.tolist(), "right": self.right.tolist(),
                "value": self.value.tolist(), "roots": self.roots.tolist()}

    @staticmethod
    def from_json(document: dict) -> "TreeEnsemble":
        return TreeEnsemble(float(document["baseline"]), np.asarray(document["feature"], np.int64),
                            np.asarray(document["threshold"], float), np.asarray(document["missing_left"], bool),
                            np.asarray(document["left"], np.int64), np.asarray(document["right"], np.int64),
                            np.asarray(document["value"], float), np.asarray(document["roots"], np.int64))


@dataclass(frozen=True)
class MaterialModel:
    """P(metal) = sigmoid(z / temperature) from TRACK_FEATURES standardised, x = (features - mean) / scale, and
    the perceived shape: with ``trees``, z = trees.raw(x followed by the shape's one-hot over SHAPE_KINDS);
    else a logistic regression with one bias per shape, z = bias[shape] + weights . x."""

    features: tuple[str, ...]
    mean: np.ndarray
    scale: np.ndarray
    weights: np.ndarray | None
    bias: dict | None
    temperature: float
    trees: TreeEnsemble | None = None

    def __post_init__(self):
        if self.features != TRACK_FEATURES:
            raise ValueError(f"material model: features {self.features} differ from the code's {TRACK_FEATURES}; retrain")
        for name in ("mean", "scale") + (() if self.trees is not None else ("weights",)):
            if getattr(self, name).shape != (len(self.features),):
                raise ValueError(f"material model: {name} expected ({len(self.features)},)")
        if self.trees is None and set(self.bias or {}) != set(SHAPE_KINDS):
            raise ValueError("material model: a bias per shape kind expected (or trees)")
        if not self.temperature > 0:
            raise ValueError("material model: a positive temperature expected")

    def log_odds(self, features: np.ndarray, shape: str) -> float:
        """Log-odds of metal, temperature applied (features: (len(TRACK_FEATURES),))."""
        x = (features - self.mean) / self.scale
        if self.trees is not None:
            z = self.trees.raw(np.concatenate([x, shape_one_hot(shape)]))
        else:
            z = self.bias[shape] + float(self.weights @ x)
        return z / self.temperature

    def to_json(self) -> dict:
        document = {"features": list(self.features), "mean": self.mean.tolist(), "scale": self.scale.tolist(),
                    "temperature": self.temperature}
        if self.trees is not None:
            return {**document, "trees": self.trees.to_json()}
        return {**document, "weights": self.weights.tolist(), "bias": dict(self.bias)}

    @staticmethod
    def from_json(document: dict) -> "MaterialModel":
        trees = TreeEnsemble.from_json(document["trees"]) if "trees" in document else None
        logistic = trees is None
        return MaterialModel(tuple(document["features"]), np.asarray(document["mean"], float), np.asarray(document["scale"], float),
                             np.asarray(document["weights"], float) if logistic else None,
                             {k: float(v) for k, v in document["bias"].items()} if logistic else None,
                             float(document["temperature"]), trees)


@lru_cache(maxsize=1)
def shipped_model() -> MaterialModel:
    """The material model shipped in the repository (MODEL_PATH)."""
    return MaterialModel.from_json(json.loads(MODEL_PATH.read_text()))


def metal_probability(windows: list[AppearanceWindow], color: str, shape: str, model: MaterialModel | None = None) -> float:
    """P(metal) of a track from its appearance windows; 0.5 when no frame gives features."""
    features = track_features(windows, color)
    if features is None:
        return 0.5
    z = (model or shipped_model()).log_odds(features, shape)
    return float(1.0 / (1.0 + np.exp(-np.clip(z, -30, 30))))
