"""Lifting tracks to the support plane by fitting projected primitives.

For a detection, the evidence map is +2 on the segment's pixels, -1 on plain
floor and 0 elsewhere (shadow-like pixels, other objects that may occlude).
The silhouette of the primitive (known size, known camera) is ray-cast at a
trial centre and slid over the evidence; the best integer shift plus a
parabolic sub-pixel step moves the centre on its plane (z = half size) through
the local pixel/metre Jacobian. Two rounds (wide, then narrow) converge. The
fit uses the whole silhouette, so objects cut by the image border, partly
segmented grey objects and shadows do not bias the centre the way a mask
centroid or a lowest-pixel contact point would. Cubes also search yaw.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from perception.background import FLOOR
from perception.geometry import ground_jacobian, primitive_window, ray_depths, silhouette, window_rays
from world.camera import backproject_to_height
from perception.types import Detection

CUBE_YAW_STEP = math.radians(7.5)
CUBE_YAWS = np.arange(0.0, math.pi / 2, CUBE_YAW_STEP)  # a cube looks the same every 90 degrees
MAX_EXTRA_ROUNDS = 3  # rounds added while the best shift keeps landing on the edge of the search


@dataclass(frozen=True)
class Fit:
    """centre: (3,) m; yaw: rad; score: overlap J = |S & D| / (|D| + |S & floor|) in [0, 1]."""

    centre: np.ndarray
    yaw: float
    score: float
    silhouette_area: int


def evidence_window(labels: np.ndarray, detection: Detection, top: int, bottom: int, left: int, right: int) -> np.ndarray:
    """(bottom-top, right-left) float32 evidence over a window that may extend past the image (zeros there)."""
    height, width = labels.shape
    out = np.zeros((bottom - top, right - left), dtype=np.float32)
    t, b, l, r = max(top, 0), min(bottom, height), max(left, 0), min(right, width)
    if b > t and r > l:
        out[t - top:b - top, l - left:r - left] = np.where(labels[t:b, l:r] == FLOOR, -1.0, 0.0)
    ys, xs = detection.ys - top, detection.xs - left
    inside = (ys >= 0) & (ys < out.shape[0]) & (xs >= 0) & (xs < out.shape[1])
    out[ys[inside], xs[inside]] = 2.0
    return out


def _parabolic(scores: np.ndarray, index: int) -> float:
    if 0 < index < len(scores) - 1:
        a, b, c = scores[index - 1], scores[index], scores[index + 1]
        denominator = a - 2 * b + c
        if denominator < 0:
            return float(np.clip(0.5 * (a - c) / denominator, -0.5, 0.5))
    return 0.0


def overlap_score(camera, kind: str, centre: np.ndarray, size: float, yaw: float, labels: np.ndarray, detection: Detection) -> tuple[float, int]:
    """J = |S & D| / (|D| + |S & floor|) of the silhouette S and detection D; and |S| (pixels)."""
    window, sil = silhouette(camera, kind, centre, size, yaw)
    if window.empty:
        return 0.0, 0
    ev = evidence_window(labels, detection, window.top, window.bottom, window.left, window.right)
    hits = float(((ev == 2.0) & sil).sum())
    floor = float(((ev == -1.0) & sil).sum())
    return hits / (detection.area + floor), int(sil.sum())


def _shift_scores(ev: np.ndarray, sil: np.ndarray, radius: int, iy: int, ix: int) -> tuple[float, float]:
    """(|S & D|, |S & floor|) of the silhouette moved by (iy - radius, ix - radius) pixels inside the evidence window."""
    h, w = sil.shape
    region = ev[iy:iy + h, ix:ix + w]
    return float(((region == 2.0) & sil).sum()), float(((region == -1.0) & sil).sum())


def shift_scores(evidence: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """Exact 'valid' correlation of an (h + 2r, w + 2r) evidence window with an (h, w) bool silhouette:
    (2r + 1, 2r + 1) float64, entry [dy, dx] = sum of the evidence under the silhouette shifted by (dy, dx).

    Each silhouette row is a few runs of pixels, so a shift's score is a sum of run totals read off the
    evidence's row prefix sums: O(runs x shifts) instead of an FFT of the window, and exact (integer
    evidence), so ties between shifts go to the first one rather than to FFT rounding noise.
    """
    height, width = mask.shape
    shifts_y, shifts_x = evidence.shape[0] - height + 1, evidence.shape[1] - width + 1
    if shifts_y < 1 or shifts_x < 1:
        raise ValueError(f"shift_scores: evidence {evidence.shape} is smaller than the silhouette {mask.shape}")
    padded = np.zeros((height, width + 2), dtype=np.int8)  # a column of zeros either side closes every run
    padded[:, 1:-1] = mask
    edges = np.diff(padded, axis=1)  # +1 at a run's first pixel, -1 after its last
    run_rows, run_starts = np.nonzero(edges == 1)
    run_ends = np.nonzero(edges == -1)[1]  # row-major order pairs each end with its start
    prefix = np.zeros((evidence.shape[0], evidence.shape[1] + 1))
    np.cumsum(evidence, axis=1, out=prefix[:, 1:])
    rows = run_rows[None, None, :] + np.arange(shifts_y)[:, None, None]
    columns = np.arange(shifts_x)[None, :, None]
    return (prefix[rows, run_ends + columns] - prefix[rows, run_starts + columns]).sum(axis=-1)


def fit_primitive(camera, kind: str, start: np.ndarray, size: float, yaw: float, labels: np.ndarray,
                  detection: Detection, radii: tuple[int, ...] = (6, 2)) -> Fit:
    """Slide the silhouette of ``kind`` over the detection's evidence; returns the fitted centre.

    One ray cast per round: within a round the silhouette is moved as a rigid
    image (its shape changes negligibly over a few pixels), and the score of
    the last round is read off the moved silhouette.
    """
    centre = np.asarray(start, dtype=float).copy()
    centre[2] = size
    score, area = 0.0, 0
    rounds, extra = list(radii), 0
    while rounds:
        radius = rounds.pop(0)
        window, sil = silhouette(camera, kind, centre, size, yaw)
        if window.empty or not sil.any():
            return Fit(centre, yaw, 0.0, 0)
        ev = evidence_window(labels, detection, window.top - radius, window.bottom + radius,
                             window.left - radius, window.right + radius)
        scores = shift_scores(ev, sil)  # (2r+1, 2r+1)
        iy, ix = np.unravel_index(int(np.argmax(scores)), scores.shape)
        hits, floor = _shift_scores(ev, sil, radius, iy, ix)
        score, area = hits / (detection.area + floor), int(sil.sum())
        dv = iy - radius + _parabolic(scores[:, ix], iy)
        du = ix - radius + _parabolic(scores[iy, :], ix)
        if du == 0 and dv == 0:
            continue
        if not rounds and max(abs(iy - radius), abs(ix - radius)) == radius and extra < MAX_EXTRA_ROUNDS:
            rounds.append(radius)  # the best shift is at the edge of the search: the object moved further, look again
            extra += 1
        jacobian = ground_jacobian(camera, centre)
        try:
            step = np.linalg.solve(jacobian, np.array([du, dv]))
        except np.linalg.LinAlgError:
            break
        centre[:2] += step
    return Fit(centre, yaw, score, area)


def fit_cube(camera, start: np.ndarray, size: float, labels: np.ndarray, detection: Detection,
             yaws: np.ndarray = CUBE_YAWS) -> Fit:
    """Cube fit over a set of yaws: coarse position with the middle yaw, then the best yaw, then refine."""
    base = fit_primitive(camera, "cube", start, size, float(yaws[len(yaws) // 2]), labels, detection, radii=(6,))
    # the window does not depend on yaw: one set of rays and one evidence window for all yaws
    window = primitive_window(camera, "cube", base.centre, size)
    best_yaw, best_score = float(yaws[len(yaws) // 2]), -1.0
    if not window.empty:
        directions = window_rays(camera, window)
        ev = evidence_window(labels, detection, window.top, window.bottom, window.left, window.right)
        segment, floor = ev == 2.0, ev == -1.0
        for yaw in yaws:
            sil = np.isfinite(ray_depths(camera, "cube", base.centre, size, float(yaw), window, directions))
            score = float((segment & sil).sum()) / (detection.area + float((floor & sil).sum()))
            if score > best_score:
                best_yaw, best_score = float(yaw), score
    return fit_primitive(camera, "cube", base.centre, size, best_yaw, labels, detection, radii=(2,))


def initial_centre(camera, detection: Detection, size: float) -> np.ndarray:
    """Centroid ray on the plane of centres (z = size): a start for the fit, (3,) m."""
    point = backproject_to_height(camera, detection.centroid[None], size)[0]
    return point if np.all(np.isfinite(point)) else np.array([0.0, 0.0, size])


TRACKING_RADIUS = 3  # px: search radius when starting from the previous frame's fit
LOST_SCORE_DROP = 0.12  # a warm-started fit this much worse than the previous frame's is redone from scratch


def fit_detection(camera, kind: str, detection: Detection, labels: np.ndarray, size: float,
                  previous: Fit | None = None) -> Fit:
    """Best pose of a known primitive for one detection.

    With ``previous`` (the fit of the frame before, nearby) the search starts
    there with a small radius and, for cubes, the yaw is tracked within +-3
    degrees; a clearly worse result falls back to the full search.
    """
    rough = initial_centre(camera, detection, size)
    warm = previous is not None and previous.score > 0 and np.linalg.norm(previous.centre[:2] - rough[:2]) < 0.3
    if not warm:
        if kind != "cube":
            return fit_primitive(camera, kind, rough, size, 0.0, labels, detection)
        return fit_cube(camera, rough, size, labels, detection)
    if kind != "cube":
        fit = fit_primitive(camera, kind, previous.centre, size, 0.0, labels, detection, radii=(TRACKING_RADIUS,))
        if fit.score < previous.score - LOST_SCORE_DROP:
            fit = max(fit, fit_primitive(camera, kind, rough, size, 0.0, labels, detection), key=lambda f: f.score)
        return fit
    near = np.mod(previous.yaw + np.radians([-3.0, 0.0, 3.0]), math.pi / 2)
    fit = max((fit_primitive(camera, "cube", previous.centre, size, float(y), labels, detection, radii=(TRACKING_RADIUS,))
               for y in near), key=lambda f: f.score)
    if fit.score < previous.score - LOST_SCORE_DROP:  # lost the pose (a hit spun it): search all
        fit = max(fit, fit_cube(camera, rough, size, labels, detection), key=lambda f: f.score)
    return fit
