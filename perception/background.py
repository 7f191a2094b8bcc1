"""Static-camera background model and per-pixel foreground evidence.

The background is the per-pixel temporal median, except where that median is
not floor (an object resting the whole video, or its shadow): there a smooth
floor model (a robust quadratic in pixel coordinates per channel) replaces it.

Per-pixel evidence in a frame, from the ratio rho_c = frame_c / background_c:

* shadow: all channels darkened by the same factor (floor chroma kept) and not
  darker than a shadow can be -> floor;
* object: chroma changed (coloured objects), much darker than any shadow
  (grey and dark objects), or brighter than the floor (highlights, bright
  colours);
* ambiguous: shadow-like darkening of medium depth, which is what a lit
  grey object looks like as well; the silhouette fit (lift.py) treats it as
  neither object nor floor.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

# Thresholds on the frame/background ratio, measured on the generator's
# fixture videos (docs/perception.md): floor shadows darken to 0.56-0.9 of the
# floor with unchanged chroma; grey rubber objects sit at 0.35-0.75.
CHROMA_OBJECT = 0.10  # max |rho_c - rho_mean| / rho_mean above which a pixel is an object
DARK_OBJECT = 0.50  # mean ratio below which a pixel is darker than any shadow
BRIGHT_OBJECT = 1.12  # mean ratio above which a pixel is brighter than the lit floor
FLOOR_RATIO = 0.92  # mean ratio above which a neutral pixel is plain floor
FLOOR_DEVIATION = 14.0  # grey levels: median pixels further than this from the floor model are not floor

FLOOR, AMBIGUOUS, OBJECT = 0, 1, 2


@dataclass(frozen=True)
class Background:
    """image: (H, W, 3) float32 RGB background; floor_fit: (H, W, 3) smooth floor model;
    static: (H, W) bool, where the temporal median was not floor (static objects, shadows)."""

    image: np.ndarray
    floor_fit: np.ndarray
    static: np.ndarray


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
    keep = np.ones(len(values), dtype=bool)
    step = max(1, len(values) // 20000)  # a subsample is plenty for 6 coefficients
    sample = np.zeros(len(values), dtype=bool)
    sample[::step] = True
    fit = values
    for _ in range(iterations):
        rows = keep & sample
        coefficients, *_ = np.linalg.lstsq(design[rows], values[rows], rcond=None)
        fit = design @ coefficients
        residual = np.abs(values - fit).max(axis=1)
        scale = max(1.4826 * float(np.median(residual[rows])), 1.0)
        keep = residual < 3.0 * scale
    return fit.reshape(height, width, 3).astype(np.float32)


def estimate_background(frames: np.ndarray, max_samples: int = 25) -> Background:
    """Background of a static-camera video.

    frames: (F, H, W, 3) uint8 RGB. Uses at most ``max_samples`` evenly spaced
    frames for the median (objects move, so each pixel is floor most of the time).
    """
    if frames.ndim != 4 or frames.shape[-1] != 3 or frames.shape[0] == 0:
        raise ValueError(f"frames: expected (F, H, W, 3) with F >= 1, got {frames.shape}")
    index = np.unique(np.linspace(0, frames.shape[0] - 1, min(max_samples, frames.shape[0])).round().astype(int))
    median = np.median(frames[index], axis=0).astype(np.float32)
    floor_fit = fit_floor(median)
    static = np.abs(median - floor_fit).max(axis=-1) > FLOOR_DEVIATION
    image = np.where(static[..., None], floor_fit, median)
    return Background(image=image, floor_fit=floor_fit, static=static)


def classify_pixels(frame: np.ndarray, background: Background) -> np.ndarray:
    """(H, W) uint8 labels FLOOR / AMBIGUOUS / OBJECT for one (H, W, 3) uint8 frame."""
    ratio = frame.astype(np.float32) / np.maximum(background.image, 1.0)
    mean = ratio.mean(axis=-1)
    chroma = np.abs(ratio - mean[..., None]).max(axis=-1) / np.maximum(mean, 0.05)
    labels = np.full(mean.shape, AMBIGUOUS, dtype=np.uint8)
    labels[(mean >= FLOOR_RATIO) & (chroma < CHROMA_OBJECT)] = FLOOR
    objects = (chroma >= CHROMA_OBJECT) | (mean < DARK_OBJECT) | (mean > BRIGHT_OBJECT)
    labels[objects] = OBJECT
    return labels
