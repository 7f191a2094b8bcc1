"""Conservative footprint separation between two bodies, vectorised over frames.

The frame-by-frame counterpart of ``world.contacts.footprint_distance`` (the
scalar, exact form the event search calls inside its root finding); the two
are checked against each other in tests/world/test_footprint.py. Used by the
``check_contact`` / ``get_event_time`` tools only when a rollout emitted no
collision event for a pair: it detects sustained (resting or sliding) contact
that the event search does not report. Horizontal footprints are circles
(sphere, upright cylinder) or yaw-rotated squares (cube); vertical extents must
overlap too, so a body flying over another is not in contact.
"""

from __future__ import annotations

import numpy as np

from world.types import Shape


def _vertical_half_extent(shape: Shape) -> float:
    return shape.rest_height


def _square_corners(center: np.ndarray, half: float, yaw: np.ndarray) -> np.ndarray:
    """center: (T, 2) m; yaw: (T,) rad -> corners (T, 4, 2) m, counter-clockwise."""
    local = np.array([[1.0, 1.0], [-1.0, 1.0], [-1.0, -1.0], [1.0, -1.0]]) * half
    cos, sin = np.cos(yaw), np.sin(yaw)
    rot = np.stack([np.stack([cos, -sin], -1), np.stack([sin, cos], -1)], -2)  # (T, 2, 2)
    return center[:, None, :] + np.einsum("tij,kj->tki", rot, local)


def _circle_circle(ca: np.ndarray, ra: float, cb: np.ndarray, rb: float) -> np.ndarray:
    return np.linalg.norm(ca - cb, axis=-1) - ra - rb


def _circle_square(c: np.ndarray, r: float, s: np.ndarray, half: float, yaw: np.ndarray) -> np.ndarray:
    """Signed gap (T,) between circles (centre c, radius r) and squares (centre s, half side, yaw)."""
    d = c - s
    cos, sin = np.cos(yaw), np.sin(yaw)
    local = np.stack([cos * d[:, 0] + sin * d[:, 1], -sin * d[:, 0] + cos * d[:, 1]], -1)
    clamped = np.clip(local, -half, half)
    outside = np.linalg.norm(local - clamped, axis=-1)
    inside_depth = np.min(half - np.abs(local), axis=-1)  # > 0 when the centre is inside
    return np.where(outside > 0, outside - r, -inside_depth - r)


def _point_segment_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """p: (..., 2); a, b: (..., 2) segment ends -> (...) distances."""
    ab = b - a
    t = np.clip(np.sum((p - a) * ab, -1) / np.maximum(np.sum(ab * ab, -1), 1e-300), 0.0, 1.0)
    return np.linalg.norm(p - (a + t[..., None] * ab), axis=-1)


def _square_square(sa: np.ndarray, ha: float, yaw_a: np.ndarray, sb: np.ndarray, hb: float, yaw_b: np.ndarray) -> np.ndarray:
    """Signed gap (T,) between two yaw-rotated squares: distance if apart, -penetration (SAT) if overlapping."""
    corners_a = _square_corners(sa, ha, yaw_a)
    corners_b = _square_corners(sb, hb, yaw_b)
    axes = np.concatenate([
        np.stack([np.cos(yaw_a), np.sin(yaw_a)], -1)[:, None], np.stack([-np.sin(yaw_a), np.cos(yaw_a)], -1)[:, None],
        np.stack([np.cos(yaw_b), np.sin(yaw_b)], -1)[:, None], np.stack([-np.sin(yaw_b), np.cos(yaw_b)], -1)[:, None],
    ], axis=1)  # (T, 4, 2)
    proj_a = np.einsum("tkj,taj->tak", corners_a, axes)  # (T, axes, corners)
    proj_b = np.einsum("tkj,taj->tak", corners_b, axes)
    overlap = np.minimum(proj_a.max(-1), proj_b.max(-1)) - np.maximum(proj_a.min(-1), proj_b.min(-1))
    penetration = overlap.min(-1)
    # Separated convex polygons: the distance is attained between a vertex and an edge.
    edges_a = (corners_a, np.roll(corners_a, -1, axis=1))
    edges_b = (corners_b, np.roll(corners_b, -1, axis=1))
    d_ab = _point_segment_distance(corners_a[:, :, None, :], edges_b[0][:, None], edges_b[1][:, None]).min(axis=(1, 2))
    d_ba = _point_segment_distance(corners_b[:, :, None, :], edges_a[0][:, None], edges_a[1][:, None]).min(axis=(1, 2))
    return np.where(penetration < 0, np.minimum(d_ab, d_ba), -penetration)


def footprint_gap(
    shape_a: Shape, position_a: np.ndarray, yaw_a: np.ndarray,
    shape_b: Shape, position_b: np.ndarray, yaw_b: np.ndarray,
) -> np.ndarray:
    """Signed surface separation between two bodies per frame.

    position_a, position_b: (T, 3) metres, world frame; yaw_a, yaw_b: (T,) rad.
    Returns (T,) metres: > 0 apart, <= 0 touching or overlapping. The larger of
    the horizontal footprint gap and the vertical gap (so both must close).
    """
    pa = np.asarray(position_a, dtype=float).reshape(-1, 3)
    pb = np.asarray(position_b, dtype=float).reshape(-1, 3)
    ya = np.asarray(yaw_a, dtype=float).reshape(-1)
    yb = np.asarray(yaw_b, dtype=float).reshape(-1)
    ca, cb = pa[:, :2], pb[:, :2]
    a_square, b_square = shape_a.kind == "cube", shape_b.kind == "cube"
    if not a_square and not b_square:
        horizontal = _circle_circle(ca, shape_a.radius, cb, shape_b.radius)
    elif a_square and b_square:
        horizontal = _square_square(ca, shape_a.half_extent, ya, cb, shape_b.half_extent, yb)
    elif a_square:
        horizontal = _circle_square(cb, shape_b.radius, ca, shape_a.half_extent, ya)
    else:
        horizontal = _circle_square(ca, shape_a.radius, cb, shape_b.half_extent, yb)
    vertical = np.abs(pa[:, 2] - pb[:, 2]) - _vertical_half_extent(shape_a) - _vertical_half_extent(shape_b)
    return np.maximum(horizontal, vertical)
