"""Static-camera background model that calibrates itself on each video, and per-pixel foreground evidence.

Background (estimate_background), from up to 25 frames spread over the video:

* per pixel the temporal median, except where the pixel spends a good part of the video in a
  shadow (a resting object's): there its bright, floor-chroma state (the 80th percentile) is the
  floor, so the shadow's ghost is not an object once the object leaves;
* where the median is still not floor (an object resting most of the video, or its shadow): on a
  textured floor, the floor the video showed there before the object came or after it left
  (_floor_seen); on a flat floor, and where no floor was seen, a smooth floor model (a robust
  quadratic in pixel coordinates per channel). "Not floor" is judged against the floor's own
  texture: a checker, granite or image floor deviates from a quadratic everywhere, so the deviation
  threshold is the video's typical deviation plus a multiple of its spread (a flat floor keeps the
  fixed 14 grey levels) and the texture stays in the background; at a resting object's place the
  smooth model is no textured floor (its squares would be objects once the object is gone);
* per pixel a noise level: the robust temporal spread (MAD) of the pixel's channel sum over the
  sampled frames, per channel, widened by a 3x3 maximum (grainy soft shadows, h264 flicker at texture edges).

Evidence in a frame (classify_pixels):

* a pixel is a *candidate* only when it leaves the range its 3x3 background neighbourhood spans,
  by more than max(8 grey levels, 3 x its noise) in some channel: a textured floor shifted by a
  pixel of compression error, or grain the pixel showed as floor, gives no evidence;
* candidates are judged by the ratio rho_c = frame_c / background_c: shadow = all channels
  darkened by the same factor (floor chroma kept, the chroma limit widened by the pixel's relative
  noise) and not darker than a shadow can be -> floor / ambiguous; object = chroma changed (coloured
  objects; below DARK_OBJECT also by more than compression's error, CANDIDATE_DIFFERENCE grey levels),
  much darker than any shadow (grey and dark objects), or brighter than the floor (highlights, bright
  colours); ambiguous = shadow-like darkening of medium depth, which is
  what a lit grey object looks like as well (the silhouette fit, lift.py, treats it as neither);
  deep = floor chroma kept but darker than any soft shadow: a grey or dark object, or the core of a
  hard shadow or of the contact shadow under an object (Blender's sun leaves 0.4 of the floor's
  light there). Deep pixels are foreground (is_foreground); inside a coloured object's segment they
  are its own shadow, which the shape decision leaves out (segment.own_shadow).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy import ndimage as ndi

# Thresholds on the frame/background ratio, measured on the generator's
# fixture videos (docs/perception.md): floor shadows darken to 0.56-0.9 of the
# floor with unchanged chroma; grey rubber objects sit at 0.35-0.75.
CHROMA_OBJECT = 0.10  # max |rho_c - rho_mean| / rho_mean above which a pixel is an object (noise-free pixel)
DARK_OBJECT = 0.50  # mean ratio below which a pixel is darker than any shadow
BRIGHT_OBJECT = 1.12  # mean ratio above which a pixel is brighter than the lit floor
FLOOR_RATIO = 0.92  # mean ratio above which a neutral pixel is plain floor
FLOOR_DEVIATION = 14.0  # grey levels: median pixels further than this from the floor model are not floor (flat floor)
TEXTURE_SPREADS = 4.0  # on a textured floor: typical deviation + this many robust spreads is still floor
CANDIDATE_DIFFERENCE = 8  # grey levels outside the 3x3 background range below which a pixel is floor (noise-free pixel)
NOISE_MULTIPLE = 3.0  # a pixel's tolerance is at least this many of its own noise levels (grey levels)
MAX_NOISE = 20.0  # grey levels: cap of the noise level (a pixel crossed by objects in most frames is not noise)
SHADOW_QUANTILE = 80  # percentile over time of a pixel's bright state (the floor seen between a resting object's shadow)
SHADOW_LIFT = 1.15  # bright state / median (mean ratio) above which, with the chroma kept, the median was a shadow
BACKGROUND_SAMPLES = 25  # frames spread over the video for the temporal statistics
MIN_FLOOR_SAMPLES = 3  # samples of a resting object's place that show the floor (before it came, after it left) to use them

FLOOR, AMBIGUOUS, OBJECT, DEEP = 0, 1, 2, 3


def is_foreground(labels: np.ndarray) -> np.ndarray:
    """(H, W) bool: the pixels segmentation groups into objects (OBJECT and DEEP labels)."""
    return labels >= OBJECT


@dataclass(frozen=True)
class Background:
    """image: (H, W, 3) float32 RGB background; floor_fit: (H, W, 3) smooth floor model;
    static: (H, W) bool, where the temporal median was not floor (static objects, shadows);
    noise: (H, W) float32 grey levels, the pixel's own temporal noise (zeros when not given)."""

    image: np.ndarray
    floor_fit: np.ndarray
    static: np.ndarray
    noise: np.ndarray | None = field(default=None)

    def __post_init__(self) -> None:
        height, width = self.image.shape[:2]
        if self.image.shape != (height, width, 3) or self.floor_fit.shape != self.image.shape:
            raise ValueError(f"Background: image and floor_fit must be (H, W, 3), got {self.image.shape} and {self.floor_fit.shape}")
        if self.static.shape != (height, width):
            raise ValueError(f"Background: static must be (H, W) = {(height, width)}, got {self.static.shape}")
        if self.noise is None:
            object.__setattr__(self, "noise", np.zeros((height, width), np.float32))
        elif self.noise.shape != (height, width):
            raise ValueError(f"Background: noise must be (H, W) = {(height, width)}, got {self.noise.shape}")


@dataclass(frozen=True)
class FloorRange:
    """Per-video precomputation of the candidate test, as (3, H, W) channel planes (a frame's channel is then
    compared plane to plane): a pixel inside [low, high] (uint8 grey levels; the range clipped to 0-255,
    which leaves the test on uint8 pixels unchanged) is floor; divisor: float32 max(background, 1), the
    denominator of the frame/background ratio; chroma_limit (H, W) float32 is the pixel's chroma threshold."""

    low: np.ndarray
    high: np.ndarray
    divisor: np.ndarray
    chroma_limit: np.ndarray


def _quadratic_design(height: int, width: int) -> np.ndarray:
    v, u = np.mgrid[0:height, 0:width].astype(np.float64)
    u = u / width - 0.5
    v = v / height - 0.5
    return np.stack([np.ones_like(u), u, v, u * u, u * v, v * v], axis=-1).reshape(-1, 6)


def fit_floor(median: np.ndarray, iterations: int = 4) -> np.ndarray:
    """Robust quadratic floor model of an (H, W, 3) image (iteratively trimmed least squares)."""
    height, width, _ = median.shape
    design = _quadratic_design(height, width)
    values = median.reshape(-1, 3).astype(np.float64)
    step = max(1, len(values) // 20000)  # a subsample is plenty for 6 coefficients
    sample_design, sample_values = design[::step], values[::step]
    keep = np.ones(len(sample_values), dtype=bool)  # only the sample's outlier flags are ever used: the rest is not computed
    for _ in range(iterations):
        coefficients, *_ = np.linalg.lstsq(sample_design[keep], sample_values[keep], rcond=None)
        residual = np.abs(sample_values - sample_design @ coefficients).max(axis=1)
        scale = max(1.4826 * float(np.median(residual[keep])), 1.0)
        keep = residual < 3.0 * scale
    fit = design @ coefficients
    return fit.reshape(height, width, 3).astype(np.float32)


def static_threshold(deviation: np.ndarray) -> float:
    """Grey levels of deviation from the smooth floor model above which a median pixel is not floor.

    deviation: (H, W) |median - floor model|, max over channels. Most pixels are floor, so the
    median deviation and its robust spread describe the floor's own texture (about 1 and 0.5 on a
    flat floor, 13-18 and 2-3 on a checker); a flat floor keeps FLOOR_DEVIATION.
    """
    typical = float(np.median(deviation))
    spread = 1.4826 * float(np.median(np.abs(deviation - typical)))
    return max(FLOOR_DEVIATION, typical + TEXTURE_SPREADS * spread)


def estimate_background(frames: np.ndarray, max_samples: int = BACKGROUND_SAMPLES) -> Background:
    """Background of a static-camera video (see the module docstring).

    frames: (F, H, W, 3) uint8 RGB. Uses at most ``max_samples`` evenly spaced frames (objects move,
    so each pixel is floor most of the time).
    """
    if frames.ndim != 4 or frames.shape[-1] != 3 or frames.shape[0] == 0:
        raise ValueError(f"frames: expected (F, H, W, 3) with F >= 1, got {frames.shape}")
    index = np.unique(np.linspace(0, frames.shape[0] - 1, min(max_samples, frames.shape[0])).round().astype(int))
    ordered = np.sort(frames[index], axis=0)  # one sort gives the median and the bright state
    count = len(index)
    median = (0.5 * (ordered[(count - 1) // 2].astype(np.float32) + ordered[count // 2])).astype(np.float32)
    bright = ordered[int(round(SHADOW_QUANTILE / 100 * (count - 1)))].astype(np.float32)
    floor_fit = fit_floor(median)  # robust: resting objects and shadows are its outliers
    deviation = np.abs(median - floor_fit).max(axis=-1)
    threshold = static_threshold(deviation)
    lift = bright / np.maximum(median, 1.0)
    lift_mean = lift.mean(axis=-1)
    kept_chroma = same_chroma(lift, lift_mean)
    # the bright state must itself look like floor: a grey object resting part of the video is not the floor
    shadowed = (lift_mean > SHADOW_LIFT) & kept_chroma & (np.abs(bright - floor_fit).max(axis=-1) <= threshold)
    unshadowed = np.where(shadowed[..., None], bright, median)
    static = np.where(shadowed, False, deviation > threshold)
    sampled = frames[index]
    # a flat floor is the smooth model; on a textured one (the threshold is its texture's) the model is no floor
    floor = _floor_seen(sampled, static, median, floor_fit, threshold) if threshold > FLOOR_DEVIATION else floor_fit
    image = np.where(static[..., None], floor, unshadowed)
    # the channel sum's noise, per channel: cheaper than per channel (summed plane by plane: a sum over a trailing axis of 3 is slow)
    grey = sampled[..., 0].astype(np.int16) + sampled[..., 1] + sampled[..., 2]
    spread = np.median(np.abs(grey - median.sum(axis=-1).astype(np.int16)), axis=0) * (1.4826 / 3.0)
    noise = np.minimum(ndi.maximum_filter(spread, size=3), MAX_NOISE).astype(np.float32)
    return Background(image=image, floor_fit=floor_fit, static=static, noise=noise)


def same_chroma(ratio: np.ndarray, ratio_mean: np.ndarray | None = None) -> np.ndarray:
    """(...) bool: the (..., 3) per-channel ratios of two colours agree within CHROMA_OBJECT of their mean
    (``ratio_mean``, computed when not given): one colour lit more or less, not another colour."""
    ratio_mean = ratio.mean(axis=-1) if ratio_mean is None else ratio_mean
    return np.abs(ratio - ratio_mean[..., None]).max(axis=-1) < CHROMA_OBJECT * ratio_mean


def _floor_seen(sampled: np.ndarray, static: np.ndarray, median: np.ndarray, floor_fit: np.ndarray,
                threshold: float) -> np.ndarray:
    """(H, W, 3) float32: where ``static`` (the median is not floor: an object resting most of the video), the
    floor as the video shows it on the samples where the pixel looks like floor (within ``threshold`` of the
    smooth model, with its chroma, and closer to it than to the median, which is the resting object; at least
    MIN_FLOOR_SAMPLES of them: before the object came to rest or after it left; their SHADOW_QUANTILE bright
    state), else the smooth model. On a textured floor the smooth model is no floor: a checker square there
    is read as an object once the resting one is gone.

    sampled: (N, H, W, 3) uint8 frames; median, floor_fit: (H, W, 3) their median and the smooth floor model;
    threshold: static_threshold.
    """
    result = floor_fit.copy()
    if not static.any():
        return result
    values = sampled[:, static].astype(np.float32)  # (N, P, 3)
    model = floor_fit[static]  # (P, 3)
    ratio = values / np.maximum(model, 1.0)
    from_model = np.abs(values - model).max(axis=-1)
    # a grey object on a textured floor can be within the floor's texture of the model: it is the median
    floor_like = (from_model <= threshold) & (from_model < np.abs(values - median[static]).max(axis=-1)) & same_chroma(ratio)
    enough = floor_like.sum(axis=0) >= MIN_FLOOR_SAMPLES
    # their bright state: a floor-like sample may be in a neighbour's soft shadow, never brighter than the floor.
    # np.nanpercentile's linear interpolation, on one sort (NaN last): nanpercentile itself loops in Python
    ordered = np.sort(np.where(floor_like[..., None], values, np.nan)[:, enough], axis=0)  # (N, Q, 3)
    position = (SHADOW_QUANTILE / 100.0) * (floor_like[:, enough].sum(axis=0) - 1)[None, :, None]  # (1, Q, 1)
    below = np.floor(position).astype(np.intp)
    low = np.take_along_axis(ordered, np.broadcast_to(below, (1, *ordered.shape[1:])), axis=0)
    high = np.take_along_axis(ordered, np.broadcast_to(np.ceil(position).astype(np.intp), (1, *ordered.shape[1:])), axis=0)
    seen = (low + (position - below) * (high - low))[0]
    rows, cols = np.nonzero(static)
    result[rows[enough], cols[enough]] = seen
    return result


def floor_range(background: Background) -> FloorRange:
    """The per-video candidate test of classify_pixels (computed once per video)."""
    tolerance = np.maximum(CANDIDATE_DIFFERENCE, NOISE_MULTIPLE * background.noise)[..., None]
    low = np.stack([ndi.minimum_filter(background.image[..., c], size=3) for c in range(3)], axis=-1) - tolerance
    high = np.stack([ndi.maximum_filter(background.image[..., c], size=3) for c in range(3)], axis=-1) + tolerance
    relative_noise = background.noise / np.maximum(background.image.mean(axis=-1), 1.0)
    chroma_limit = CHROMA_OBJECT + NOISE_MULTIPLE * relative_noise
    low_planes = np.ascontiguousarray(np.clip(np.floor(low), 0, 255).astype(np.uint8).transpose(2, 0, 1))
    high_planes = np.ascontiguousarray(np.clip(np.ceil(high), 0, 255).astype(np.uint8).transpose(2, 0, 1))
    divisor = np.ascontiguousarray(np.maximum(background.image, 1.0).astype(np.float32).transpose(2, 0, 1))
    return FloorRange(low_planes, high_planes, divisor, chroma_limit.astype(np.float32))


def classify_pixels(frame: np.ndarray, background: Background, bounds: FloorRange | None = None) -> np.ndarray:
    """(H, W) uint8 labels FLOOR / AMBIGUOUS / OBJECT / DEEP for one (H, W, 3) uint8 frame; only pixels
    outside their floor range are examined (bounds: floor_range(background), once per video)."""
    bounds = floor_range(background) if bounds is None else bounds
    if frame.dtype != np.uint8:
        raise ValueError(f"frame: expected uint8 pixels, got {frame.dtype}")
    height, width = frame.shape[:2]
    candidate = np.zeros((height, width), dtype=bool)
    for channel in range(3):  # per channel plane: array ops over a trailing axis of 3 are slow in numpy
        value = frame[..., channel]
        candidate |= value < bounds.low[channel]
        candidate |= value > bounds.high[channel]
    labels = np.zeros((height, width), dtype=np.uint8)
    where = np.flatnonzero(candidate)
    if where.size == 0:
        return labels
    pixels = frame.reshape(-1, 3)[where]
    floor = [bounds.divisor[c].ravel()[where] for c in range(3)]
    ratio = [pixels[:, c].astype(np.float32) / floor[c] for c in range(3)]
    mean = (ratio[0] + ratio[1] + ratio[2]) / 3  # float32, summed in channel order as ndarray.mean over 3 channels
    off = [np.abs(ratio[c] - mean) for c in range(3)]
    chroma = np.maximum(np.maximum(off[0], off[1]), off[2]) / np.maximum(mean, 0.05)
    # below DARK_OBJECT a chroma change is evidence only when it exceeds what compression does to any pixel (grey
    # levels): in a deep shadow a few levels of h264 colour error are a large share of the pixel (Blender's sky-lit
    # shadows on a blue-grey floor, (30, 41, 51) where the darkened floor is (35, 43, 45), were objects). Either way
    # the pixel is foreground (OBJECT or DEEP): segments keep their pixels, the deep ones say "the floor darkened"
    levels = np.maximum(np.maximum(off[0] * floor[0], off[1] * floor[1]), off[2] * floor[2])
    coloured = (chroma >= bounds.chroma_limit.ravel()[where]) & ((levels >= CANDIDATE_DIFFERENCE) | (mean >= DARK_OBJECT))
    label = np.full(where.shape, AMBIGUOUS, dtype=np.uint8)
    label[(mean >= FLOOR_RATIO) & ~coloured] = FLOOR
    label[coloured | (mean > BRIGHT_OBJECT)] = OBJECT
    label[~coloured & (mean < DARK_OBJECT)] = DEEP
    labels.ravel()[where] = label
    return labels
