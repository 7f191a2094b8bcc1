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

With ``free_top`` (an object whose paint has the floor's chroma, segment.paint_like_floor) plain floor
under the primitive's upward surface (geometry.upward_surface) counts as shadow-like pixels do, neither
for nor against, and a segment pixel there half (TOP_SEGMENT_EVIDENCE): a top face gets the light the
floor gets, so a grey top on a grey floor is labelled floor, and counting it against the primitive slid
the fit toward the camera, onto its free shadow, by up to half the object.

With the video's light (``reach``, perception.shadows) the primitive's cast shadow moves with it (``cast``): a
shadow-like pixel under that shadow, in the segment or outside it, counts as a segment pixel under the silhouette.
A grey object's segment may hold its own deep shadow; the body and its shadow then explain the image together.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from perception.background import AMBIGUOUS, DEEP, FLOOR
from perception.geometry import Box2D, ground_jacobian, primitive_window, ray_depths, silhouette, silhouette_and_top, upward_surface, window_rays
from perception.shadows import shadow_in_window, shadow_window
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


def cast(camera, kind: str, centre: np.ndarray, size: float, yaw: float, free_top: bool = False,
         reach: np.ndarray | None = None) -> tuple[Box2D, np.ndarray, np.ndarray | None, np.ndarray | None]:
    """One ray cast of a primitive: window, (h, w) bool silhouette, upward surface (free_top, else None) and, with a
    light's ``reach`` (shadows.estimate_reach), the floor in its shadow outside the silhouette (else None)."""
    if reach is None:
        window, sil, top = silhouette_and_top(camera, kind, centre, size, yaw, with_top=free_top)
        return window, sil, top, None
    window = shadow_window(camera, kind, centre, size, reach)
    body = primitive_window(camera, kind, centre, size)  # inside ``window``: the primitive is ray-cast there only
    directions = window_rays(camera, body)
    depths = ray_depths(camera, kind, centre, size, yaw, body, directions)
    inner = _inner(window, body)
    sil = np.zeros(window.shape, dtype=bool)
    sil[inner] = np.isfinite(depths)
    top = None
    if free_top:
        top = np.zeros(window.shape, dtype=bool)
        top[inner] = upward_surface(camera, kind, centre, size, depths, body, directions)
    return window, sil, top, shadow_in_window(camera, kind, centre, size, yaw, reach, window) & ~sil


def _inner(outer: Box2D, inner: Box2D) -> tuple[slice, slice]:
    """The slices of ``outer``'s (h, w) arrays that ``inner`` (a window inside it) covers."""
    return (slice(inner.top - outer.top, inner.bottom - outer.top), slice(inner.left - outer.left, inner.right - outer.left))


def shadow_like_window(labels: np.ndarray, top: int, bottom: int, left: int, right: int) -> np.ndarray:
    """(bottom-top, right-left) bool over a window that may extend past the image (False there): the pixels that
    look like a shadow, deep or ambiguous (the floor's chroma, darker). A lit face or a paint (object) never is."""
    height, width = labels.shape
    out = np.zeros((bottom - top, right - left), dtype=bool)
    t, b, l, r = max(top, 0), min(bottom, height), max(left, 0), min(right, width)
    if b > t and r > l:
        region = labels[t:b, l:r]
        out[t - top:b - top, l - left:r - left] = (region == DEEP) | (region == AMBIGUOUS)
    return out


def shadow_explained(camera, kind: str, fit: Fit, size: float, detection: Detection, labels: np.ndarray,
                     reach: np.ndarray | None) -> tuple[np.ndarray, int]:
    """What the fitted primitive's shadow explains (labels: the frame's (H, W) pixel labels; reach: the light,
    shadows.estimate_reach): (area,) bool, the detection's shadow-like pixels under it, and the number of
    shadow-like pixels under it outside the detection. Nothing without a light."""
    if reach is None:
        return np.zeros(detection.area, dtype=bool), 0
    window, _, _, shade = cast(camera, kind, fit.centre, size, fit.yaw, reach=reach)
    dark = shadow_like_window(labels, window.top, window.bottom, window.left, window.right) & shade
    ys, xs = detection.ys - window.top, detection.xs - window.left
    inside = (ys >= 0) & (ys < dark.shape[0]) & (xs >= 0) & (xs < dark.shape[1])
    explained = np.zeros(detection.area, dtype=bool)
    explained[inside] = dark[ys[inside], xs[inside]]
    return explained, int(dark.sum()) - int(explained.sum())


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


def _shift_scores(ev: np.ndarray, sil: np.ndarray, radius: int, iy: int, ix: int, free: np.ndarray | None = None,
                  shade: np.ndarray | None = None, dark: np.ndarray | None = None) -> tuple[float, float]:
    """(|S & D|, |S & floor|) of the silhouette moved by (iy - radius, ix - radius) pixels inside the evidence window;
    floor under ``free`` (a part of S, same shape) is not counted. With ``shade`` (its shadow outside it, same
    shape) and ``dark`` (shadow_like_window over the evidence window), the shadow-like pixels under the shade count
    with S & D, and those outside the segment with |D| too (they are explained, not missed)."""
    h, w = sil.shape
    region = ev[iy:iy + h, ix:ix + w]
    costly = sil if free is None else sil & ~free
    hits, cost = float(((region == 2.0) & sil).sum()), float(((region == -1.0) & costly).sum())
    if shade is not None:
        shaded = dark[iy:iy + h, ix:ix + w] & shade
        outside = float((shaded & (region != 2.0)).sum())
        hits += float(shaded.sum())
        cost += outside
    return hits, cost


# Evidence of a segment pixel under a free top (the segment's pixels elsewhere: 2). A top lit as the floor is
# expected to look like floor; were segment pixels as good there, a fit sliding toward the camera (its top over
# the object's sides, its sides over the free shadow) would tie with the true pose.
TOP_SEGMENT_EVIDENCE = 1.0


def _all_shift_scores(evidence: np.ndarray, sil: np.ndarray, free: np.ndarray | None, shade: np.ndarray | None = None,
                      dark: np.ndarray | None = None) -> np.ndarray:
    """shift_scores of the silhouette; under ``free`` (a part of it) floor costs nothing and a segment pixel
    counts TOP_SEGMENT_EVIDENCE; under ``shade`` (its shadow outside it) a shadow-like pixel (``dark``:
    shadow_like_window over the evidence window), in the segment or not, counts as a segment pixel under the
    silhouette: the body and its shadow explain the image (a grey object's segment holds its deep shadow; a fit
    sliding towards the light, its shadow over the object's own dark sides, leaves the true shadow unexplained)."""
    if free is None or not free.any():
        scores = shift_scores(evidence, sil)
    else:
        scores = shift_scores(evidence, sil & ~free) + shift_scores(np.where(evidence > 0, TOP_SEGMENT_EVIDENCE, 0.0), free)
    if shade is not None and shade.any():
        scores = scores + shift_scores(np.where(dark, 2.0, 0.0), shade)
    return scores


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
                  detection: Detection, radii: tuple[int, ...] = (6, 2), free_top: bool = False,
                  reach: np.ndarray | None = None) -> Fit:
    """Slide the silhouette of ``kind`` over the detection's evidence; returns the fitted centre.

    One ray cast per round: within a round the silhouette is moved as a rigid
    image (its shape changes negligibly over a few pixels), and the score of
    the last round is read off the moved silhouette. With a light's ``reach``
    (shadows.estimate_reach) the primitive's shadow moves with it and explains
    the segment's pixels it covers (a grey object's segment holds its deep shadow).
    """
    centre = np.asarray(start, dtype=float).copy()
    centre[2] = size
    score, area = 0.0, 0
    rounds, extra = list(radii), 0
    while rounds:
        radius = rounds.pop(0)
        window, sil, top, shade = cast(camera, kind, centre, size, yaw, free_top, reach)
        if window.empty or not sil.any():
            return Fit(centre, yaw, 0.0, 0)
        ev = evidence_window(labels, detection, window.top - radius, window.bottom + radius,
                             window.left - radius, window.right + radius)
        dark = None if shade is None else shadow_like_window(labels, window.top - radius, window.bottom + radius,
                                                            window.left - radius, window.right + radius)
        scores = _all_shift_scores(ev, sil, top, shade, dark)  # (2r+1, 2r+1)
        iy, ix = np.unravel_index(int(np.argmax(scores)), scores.shape)
        hits, floor = _shift_scores(ev, sil, radius, iy, ix, top, shade, dark)
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
             yaws: np.ndarray = CUBE_YAWS, free_top: bool = False, reach: np.ndarray | None = None) -> Fit:
    """Cube fit over a set of yaws: coarse position with the middle yaw, then the best yaw, then refine
    (free_top, reach: as fit_primitive)."""
    base = fit_primitive(camera, "cube", start, size, float(yaws[len(yaws) // 2]), labels, detection, radii=(6,),
                         free_top=free_top, reach=reach)
    # the window does not depend on yaw: one set of rays and one evidence window for all yaws; the yaw is read off
    # the body (the shadow moves the pose, not the yaw: fit_primitive below refines with it)
    window = primitive_window(camera, "cube", base.centre, size)
    best_yaw, best_score = float(yaws[len(yaws) // 2]), -1.0
    if not window.empty:
        directions = window_rays(camera, window)
        ev = evidence_window(labels, detection, window.top, window.bottom, window.left, window.right)
        segment, floor = ev == 2.0, ev == -1.0
        for yaw in yaws:
            depths = ray_depths(camera, "cube", base.centre, size, float(yaw), window, directions)
            sil = np.isfinite(depths)
            costly = sil & ~upward_surface(camera, "cube", base.centre, size, depths, window, directions) if free_top else sil
            score = float((segment & sil).sum()) / (detection.area + float((floor & costly).sum()))
            if score > best_score:
                best_yaw, best_score = float(yaw), score
    return fit_primitive(camera, "cube", base.centre, size, best_yaw, labels, detection, radii=(2,), free_top=free_top, reach=reach)


def initial_centre(camera, detection: Detection, size: float) -> np.ndarray:
    """Centroid ray on the plane of centres (z = size): a start for the fit, (3,) m."""
    point = backproject_to_height(camera, detection.centroid[None], size)[0]
    return point if np.all(np.isfinite(point)) else np.array([0.0, 0.0, size])


TRACKING_RADIUS = 3  # px: search radius when starting from the previous frame's fit
# A warm-started fit scoring below this is compared with a search from scratch: a warm start keeps a pose
# that explains most of the segment (a cube at the wrong yaw slid onto its free shadow) for the rest of the track.
WARM_TRUSTED_SCORE = 0.95


def fit_detection(camera, kind: str, detection: Detection, labels: np.ndarray, size: float,
                  previous: Fit | None = None, free_top: bool = False, reach: np.ndarray | None = None) -> Fit:
    """Best pose of a known primitive for one detection (free_top, reach: as fit_primitive).

    With ``previous`` (the fit of the frame before, nearby) the search starts
    there with a small radius and, for cubes, the yaw is tracked within +-3
    degrees; a result below WARM_TRUSTED_SCORE is compared with the full search.
    """
    rough = initial_centre(camera, detection, size)
    warm = previous is not None and previous.score > 0 and np.linalg.norm(previous.centre[:2] - rough[:2]) < 0.3

    def primitive(start: np.ndarray, yaw: float = 0.0, radii: tuple[int, ...] = (6, 2)) -> Fit:
        return fit_primitive(camera, kind, start, size, yaw, labels, detection, radii=radii, free_top=free_top, reach=reach)

    if not warm:
        return primitive(rough) if kind != "cube" else fit_cube(camera, rough, size, labels, detection, free_top=free_top, reach=reach)
    if kind != "cube":
        fit = primitive(previous.centre, radii=(TRACKING_RADIUS,))
        if fit.score < WARM_TRUSTED_SCORE:
            fit = max(fit, primitive(rough), key=lambda f: f.score)
        return fit
    near = np.mod(previous.yaw + np.radians([-3.0, 0.0, 3.0]), math.pi / 2)
    fit = max((primitive(previous.centre, float(y), (TRACKING_RADIUS,)) for y in near), key=lambda f: f.score)
    if fit.score < WARM_TRUSTED_SCORE:  # lost the pose (a hit spun it), or never had it: search all
        fit = max(fit, fit_cube(camera, rough, size, labels, detection, free_top=free_top, reach=reach), key=lambda f: f.score)
    return fit
