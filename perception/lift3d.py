"""3D lifting of an airborne object from a calibrated camera with the ballistic constraint (Physion, from video).

A flying object's centre follows p(t) = p0 + v0 t + g t^2 / 2 with g = (0, 0, -g)
known. Each frame's pixel centre gives a viewing ray from the camera centre c
along a unit direction d_k; the centre lies on it when d_k x (p(t_k) - c) = 0,
which is LINEAR in the six unknowns (p0, v0):

    [d_k]x p0 + t_k [d_k]x v0 = [d_k]x (c - g t_k^2 / 2)

so least squares over the frames of one arc gives the arc in metres: the
known gravity fixes the depth that a single view cannot. The residual of each
row is the centre's distance from the ray (m); rows are weighted by 1 / depth
so the fit minimises (approximately) pixel error. Degenerate when the arc is
too short or moves along the viewing rays (the condition number says so).

``colour_centres`` finds the pixel centre of a uniformly coloured object
(the red agent) in each frame: the centroid of its mask.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from world.camera import pixel_rays, project_with_depth
from world.types import STANDARD_GRAVITY, Camera

MIN_ARC_FRAMES = 4  # six unknowns, two independent equations per frame, and one frame of redundancy
RED_MIN = 100  # red channel of the agent's pixels (0-255)
RED_DOMINANCE = 1.8  # red at least this many times green and blue


@dataclass(frozen=True)
class BallisticArc:
    """p0, v0: (3,) centre (m) and velocity (m/s) at ``t0`` (s); rms_ray_distance: m, the centres' mean
    distance from their viewing rays; condition: of the weighted design (large = poorly determined)."""

    t0: float
    p0: np.ndarray
    v0: np.ndarray
    rms_ray_distance: float
    condition: float

    def positions(self, times: np.ndarray, gravity: float = STANDARD_GRAVITY) -> np.ndarray:
        """(K, 3) centres at times (K,) s."""
        tau = np.asarray(times, float)[:, None] - self.t0
        return self.p0 + self.v0 * tau + 0.5 * np.array([0.0, 0.0, -gravity]) * tau**2


def _cross_matrix(d: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -d[2], d[1]], [d[2], 0.0, -d[0]], [-d[1], d[0], 0.0]])


def ballistic_lift(camera: Camera, times: np.ndarray, pixels: np.ndarray, gravity: float = STANDARD_GRAVITY) -> BallisticArc:
    """The ballistic arc through the viewing rays of ``pixels`` (K, 2) at ``times`` (K,) s; ValueError if too few."""
    times = np.asarray(times, float)
    pixels = np.asarray(pixels, float)
    keep = np.all(np.isfinite(pixels), axis=1)
    times, pixels = times[keep], pixels[keep]
    if len(times) < MIN_ARC_FRAMES:
        raise ValueError(f"ballistic lift: {len(times)} frames with a pixel centre, need at least {MIN_ARC_FRAMES}")
    t0 = float(times[0])
    tau = times - t0
    rays = pixel_rays(camera, pixels[:, 0], pixels[:, 1])
    rays /= np.linalg.norm(rays, axis=1, keepdims=True)
    centre = np.asarray(camera.position, float)
    g_vec = np.array([0.0, 0.0, -gravity])
    weights = np.ones(len(times))
    for _ in range(2):  # the second pass weights by the depths of the first
        rows, rhs = [], []
        for k in range(len(times)):
            cross = _cross_matrix(rays[k]) * weights[k]
            rows.append(np.hstack([cross, tau[k] * cross]))
            rhs.append(cross @ (centre - 0.5 * g_vec * tau[k] ** 2))
        design, target = np.vstack(rows), np.concatenate(rhs)
        solution, *_ = np.linalg.lstsq(design, target, rcond=None)
        p0, v0 = solution[:3], solution[3:]
        _, depth = project_with_depth(camera, p0 + np.outer(tau, v0) + 0.5 * np.outer(tau**2, g_vec))
        weights = 1.0 / np.maximum(depth, 1e-3)
    points = p0 + np.outer(tau, v0) + 0.5 * np.outer(tau**2, g_vec)
    distances = np.linalg.norm(np.cross(points - centre, rays), axis=1)
    return BallisticArc(t0, p0, v0, float(np.sqrt(np.mean(distances**2))), float(np.linalg.cond(design)))


def colour_centres(frames: np.ndarray, min_pixels: int = 6) -> np.ndarray:
    """(T, 2) pixel centroids (u, v) of the red pixels of frames (T, H, W, 3) uint8; NaN where fewer than ``min_pixels``."""
    frames = np.asarray(frames)
    red, green, blue = (frames[..., c].astype(float) for c in range(3))
    mask = (red >= RED_MIN) & (red >= RED_DOMINANCE * green) & (red >= RED_DOMINANCE * blue)
    out = np.full((len(frames), 2), np.nan)
    for k, m in enumerate(mask):
        vs, us = np.nonzero(m)
        if len(us) >= min_pixels:
            out[k] = (us.mean(), vs.mean())
    return out
