"""Cast shadows of the primitives under one distant light, the light estimated from the video itself.

A distant light moves the shadow of a point at height h by h x ``reach`` on the floor: ``reach`` (2,) is the
light's direction d (from the light, d_z < 0) as d_xy / -d_z, metres of floor per metre of height (0 for a light
overhead, cot(elevation) long). The shadow of a primitive standing on the floor is then closed form in floor
coordinates relative to its centre (``in_shadow``): a cylinder's is its footprint disc swept along the segment
[0, 2 size x reach], a cube's its footprint square swept along it, a sphere's the floor points whose line towards
the light passes within a radius of its centre.

``estimate_reach`` calibrates the light on each video: the coloured objects, whose pose lifting gets right from
their paint alone, are placed at their fitted poses and the reach whose predicted shadows cover the most
shadow-like pixels and the least plain floor around them wins (a coarse grid of azimuth x elevation, then a finer
one around the best). A video without a clear shadow (soft or absent, or no coloured object) gets None, and
lifting then ignores shadows as before. Area lights are not distant, but over an object's few sizes their
shadows move as a distant light's would.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from perception.background import AMBIGUOUS, DEEP, FLOOR
from perception.geometry import Box2D, floor_planes, floor_points, primitive_window
from world.camera import project

MIN_ELEVATION_DEG = 25.0  # lower lights than this cast shadows longer than the search window
MAX_ELEVATION_DEG = 85.0  # nearly overhead: the shadow hides under the object, no evidence either way
COARSE_AZIMUTHS = 24
COARSE_ELEVATIONS = 13
FINE_STEPS = 7  # per axis, around the coarse best, one coarse step wide
PIXEL_STRIDE = 2  # every other pixel of a sample's window (the shadow is many pixels wide)
MIN_SHADOW_PURITY = 0.6  # share of shadow-like pixels (not floor) inside the best reach's predicted shadows
MIN_SHADOW_PIXELS = 150  # sampled shadow-like pixels inside them over all samples: fewer is no evidence


def in_shadow(kind: str, size: float, yaw: float | np.ndarray, offsets: np.ndarray, reach: np.ndarray) -> np.ndarray:
    """(...,) bool: floor points at ``offsets`` (..., 2) m from a primitive's centre lie in its shadow.

    kind: sphere (radius size, centre at height size), cylinder (radius = half height = size), cube (half side
    size, yaw rad about +z; a scalar or an array broadcast against offsets[..., 0]); reach: (2,) as the module
    docstring. The primitive's own footprint is in its shadow.
    """
    return _in_shadow_xy(kind, size, yaw, offsets[..., 0], offsets[..., 1], reach)


def _in_shadow_xy(kind: str, size: float, yaw: float | np.ndarray, qx: np.ndarray, qy: np.ndarray, reach: np.ndarray) -> np.ndarray:
    """in_shadow with the offsets' x and y as two arrays of one shape (contiguous planes are faster)."""
    kx, ky = float(reach[0]), float(reach[1])
    if kind == "sphere":
        # the floor point's line towards the light, (q - h reach, h), passes within size of (0, 0, size)
        vv = kx * kx + ky * ky + 1.0
        wv = -(qx * kx + qy * ky) - size
        return qx * qx + qy * qy + size * size - wv * wv / vv <= size * size
    top = 2.0 * size  # the shadow of the primitive's points up to its top
    if kind == "cylinder":
        kk = kx * kx + ky * ky
        z = np.clip((qx * kx + qy * ky) / kk, 0.0, top) if kk > 1e-12 else np.zeros_like(qx)
        return (qx - z * kx) ** 2 + (qy - z * ky) ** 2 <= size * size
    if kind == "cube":
        c, s = np.cos(yaw), np.sin(yaw)
        low, high = np.zeros_like(qx), np.full_like(qx, top)
        for q, k in ((c * qx + s * qy, c * kx + s * ky), (-s * qx + c * qy, -s * kx + c * ky)):
            # heights z at which the footprint moved by z reach still covers q along this body axis
            k = np.broadcast_to(k, q.shape)
            flat = np.abs(k) < 1e-9
            safe = np.where(flat, 1.0, k)
            a, b = (q - size) / safe, (q + size) / safe
            low = np.maximum(low, np.where(flat, np.where(np.abs(q) <= size, -np.inf, np.inf), np.minimum(a, b)))
            high = np.minimum(high, np.where(flat, np.inf, np.maximum(a, b)))
        return low <= high
    raise ValueError(f"kind: expected sphere, cube or cylinder, got {kind!r}")


def shadow_in_window(camera, kind: str, centre: np.ndarray, size: float, yaw: float, reach: np.ndarray,
                     window: Box2D) -> np.ndarray:
    """(h, w) bool: the window's pixels that see floor in the primitive's shadow (its own silhouette included)."""
    xs, ys = floor_planes(camera)
    rows, columns = slice(window.top, window.bottom), slice(window.left, window.right)
    qx, qy = xs[rows, columns] - np.float32(centre[0]), ys[rows, columns] - np.float32(centre[1])
    with np.errstate(invalid="ignore"):  # NaN floor points (above the horizon) compare False
        if kind == "cylinder":
            return _in_shadow_xy(kind, size, yaw, qx, qy, reach)
        # every primitive's shadow lies within its footprint's circumradius of the segment [0, 2 size x reach]:
        # the exact test runs on those pixels only
        near = _in_shadow_xy("cylinder", size * math.sqrt(2.0), 0.0, qx, qy, reach / math.sqrt(2.0))
        out = np.zeros(near.shape, dtype=bool)
        out[near] = _in_shadow_xy(kind, size, yaw, qx[near], qy[near], reach)
        return out


def shadow_reach_points(centre: np.ndarray, size: float, reach: np.ndarray) -> np.ndarray:
    """(8, 3) floor points bounding the shadow of a primitive of half-size ``size`` at ``centre``: its footprint
    box's corners and the same moved by its height x reach."""
    reach_out = size * math.sqrt(2.0)
    corners = np.array([[dx, dy] for dx in (-reach_out, reach_out) for dy in (-reach_out, reach_out)])
    base = np.asarray(centre, float)[:2] + corners
    moved = base + 2.0 * size * np.asarray(reach, float)
    points = np.zeros((8, 3))
    points[:4, :2], points[4:, :2] = base, moved
    return points


def shadow_window(camera, kind: str, centre: np.ndarray, size: float, reach: np.ndarray, margin: int = 2) -> Box2D:
    """Pixel window that holds a primitive's silhouette and its shadow (clipped to the image)."""
    window = primitive_window(camera, kind, centre, size, margin)
    pixels = project(camera, shadow_reach_points(centre, size, reach))
    if window.empty or np.any(~np.isfinite(pixels)):
        return window
    return Box2D(max(min(window.top, int(math.floor(pixels[:, 1].min())) - margin), 0),
                 min(max(window.bottom, int(math.ceil(pixels[:, 1].max())) + margin + 1), camera.height),
                 max(min(window.left, int(math.floor(pixels[:, 0].min())) - margin), 0),
                 min(max(window.right, int(math.ceil(pixels[:, 0].max())) + margin + 1), camera.width))


def reach_of(azimuth: float, elevation: float) -> np.ndarray:
    """(2,) reach of a light coming from ``azimuth`` (rad, from +x counter-clockwise) at ``elevation`` (rad):
    shadows fall away from the light, cot(elevation) per metre of height."""
    length = 1.0 / math.tan(elevation)
    return -length * np.array([math.cos(azimuth), math.sin(azimuth)])


@dataclass(frozen=True)
class ShadowSample:
    """One coloured object on one frame, for estimate_reach.

    kind, size (m), yaw (rad): its primitive; offsets: (n, 2) m floor points of the window's sampled pixels around
    it, relative to its fitted centre, where they show plain floor or shadow-like pixels outside its silhouette;
    dark: (n,) bool, shadow-like (ambiguous or deep) rather than plain floor.
    """

    kind: str
    size: float
    yaw: float
    offsets: np.ndarray
    dark: np.ndarray


def shadow_sample(camera, labels: np.ndarray, kind: str, centre: np.ndarray, size: float, yaw: float,
                  silhouette_window: Box2D, silhouette: np.ndarray) -> ShadowSample:
    """The sample of a primitive fitted at ``centre`` on a frame with (H, W) pixel labels; its silhouette
    (h, w) bool over ``silhouette_window`` is left out (the object hides the shadow behind it)."""
    radius = 2.0 * size / math.tan(math.radians(MIN_ELEVATION_DEG)) + size * math.sqrt(2.0)
    points = floor_points(camera)
    offsets = points[::PIXEL_STRIDE, ::PIXEL_STRIDE] - np.asarray(centre, float)[:2]
    sampled = labels[::PIXEL_STRIDE, ::PIXEL_STRIDE]
    hidden = np.zeros(labels.shape, dtype=bool)
    w = silhouette_window
    hidden[w.top:w.bottom, w.left:w.right] = silhouette
    with np.errstate(invalid="ignore"):
        near = (np.abs(offsets[..., 0]) <= radius) & (np.abs(offsets[..., 1]) <= radius)
    dark = (sampled == AMBIGUOUS) | (sampled == DEEP)
    keep = near & (dark | (sampled == FLOOR)) & ~hidden[::PIXEL_STRIDE, ::PIXEL_STRIDE]
    return ShadowSample(kind, size, yaw, offsets[keep], dark[keep])


def _score(samples: list[ShadowSample], reach: np.ndarray) -> tuple[float, float]:
    """(shadow-like pixels, plain floor pixels) inside the samples' predicted shadows."""
    dark_in, floor_in = 0.0, 0.0
    for sample in samples:
        inside = in_shadow(sample.kind, sample.size, sample.yaw, sample.offsets, reach)
        dark_in += float(np.count_nonzero(inside & sample.dark))
        floor_in += float(np.count_nonzero(inside & ~sample.dark))
    return dark_in, floor_in


def estimate_reach(samples: list[ShadowSample]) -> np.ndarray | None:
    """(2,) reach (module docstring) whose shadows best explain the samples, or None without clear shadows."""
    if not samples:
        return None
    low, high = math.radians(MIN_ELEVATION_DEG), math.radians(MAX_ELEVATION_DEG)

    def best_of(azimuths: np.ndarray, elevations: np.ndarray) -> tuple[float, float, float, float, float]:
        best = (-math.inf, 0.0, 0.0, 0.0, 0.0)
        for elevation in elevations:
            for azimuth in azimuths:
                dark_in, floor_in = _score(samples, reach_of(azimuth, elevation))
                if dark_in - floor_in > best[0]:
                    best = (dark_in - floor_in, float(azimuth), float(elevation), dark_in, floor_in)
        return best

    azimuth_step = 2 * math.pi / COARSE_AZIMUTHS
    elevation_step = (high - low) / (COARSE_ELEVATIONS - 1)
    _, azimuth, elevation, _, _ = best_of(np.arange(COARSE_AZIMUTHS) * azimuth_step, np.linspace(low, high, COARSE_ELEVATIONS))
    around = np.linspace(-0.5, 0.5, FINE_STEPS)
    _, azimuth, elevation, dark_in, floor_in = best_of(
        azimuth + around * azimuth_step, np.clip(elevation + around * elevation_step, low, high))
    if dark_in < MIN_SHADOW_PIXELS or dark_in < MIN_SHADOW_PURITY * (dark_in + floor_in):
        return None
    return reach_of(azimuth, elevation)
