"""Pinhole projection, footprint outlines and view events (CLEVRER-style in/out).

A body is *visible* at a frame when it is active and its centre projects inside
the image with positive depth (``centre_in_view``: the generator's
``inside_camera_view`` rule, so a body resting just past the border with part of
its footprint still in the picture has left the view). Events follow CLEVRER:
``in`` is the first visible frame of a visibility run that starts after frame 0,
``out`` the first frame no longer visible (a body removed by an edit does not
"leave the view").
"""

from __future__ import annotations

import math

import numpy as np

from world.types import Camera, Shape

_UNIT_OUTLINE = np.array(
    [[0.0, 0.0]] + [[math.cos(a), math.sin(a)] for a in np.linspace(0.0, 2.0 * math.pi, 8, endpoint=False)]
)
_SQUARE_OUTLINE = np.array([[0, 0], [1, 0], [1, 1], [0, 1], [-1, 1], [-1, 0], [-1, -1], [0, -1], [1, -1]], dtype=float)


def project(camera: Camera, points: np.ndarray) -> np.ndarray:
    """Project world points to pixels.

    points: (..., 3) world frame, metres. Returns (..., 2) pixel coordinates
    (u right, v down); points behind the camera get NaN.
    """
    pixels, _ = project_with_depth(camera, points)
    return pixels


def project_with_depth(camera: Camera, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Pixels (..., 2) and camera-frame depth (...,) in metres (<= 0 behind the camera)."""
    points = np.asarray(points, dtype=float)
    if points.shape[-1] != 3:
        raise ValueError(f"points: expected shape (..., 3), got {points.shape}")
    rotation = np.asarray(camera.rotation)
    # rotation maps camera -> world, so world -> camera is its transpose.
    cam = (points - np.asarray(camera.position)) @ rotation
    depth = cam[..., 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        safe = np.where(depth > 1e-9, depth, np.nan)
        u = camera.fx * cam[..., 0] / safe + camera.cx
        v = camera.fy * cam[..., 1] / safe + camera.cy
    return np.stack([u, v], axis=-1), depth


def pixel_rays(camera: Camera, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """World-frame (unnormalised) ray directions through pixels; u, v (...,) -> (..., 3)."""
    rays_cam = np.stack([(np.asarray(u, float) - camera.cx) / camera.fx, (np.asarray(v, float) - camera.cy) / camera.fy,
                         np.ones(np.shape(u))], axis=-1)
    return rays_cam @ np.asarray(camera.rotation).T


def backproject_to_height(camera: Camera, pixels: np.ndarray, height: float) -> np.ndarray:
    """Intersect the rays of pixels (M, 2) with the plane z = height (metres); (M, 3) world points.

    Rays that do not go down to the plane (horizon and above) give NaN.
    """
    pixels = np.asarray(pixels, dtype=float).reshape(-1, 2)
    rays = pixel_rays(camera, pixels[:, 0], pixels[:, 1])
    origin = np.asarray(camera.position)
    with np.errstate(divide="ignore", invalid="ignore"):
        scale = (height - origin[2]) / rays[:, 2]
    scale = np.where(scale > 0, scale, np.nan)
    return origin + rays * scale[:, None]


def footprint_outline(shape: Shape, positions: np.ndarray, yaw: np.ndarray) -> np.ndarray:
    """Outline points of a body's footprint on the plane z = 0.

    positions: (T, 3) body centres, metres; yaw: (T,) radians.
    Returns (T, 9, 3) world points.
    """
    if shape.kind == "cube":
        local = _SQUARE_OUTLINE * shape.half_extent
    else:
        local = _UNIT_OUTLINE * shape.radius
    c, s = np.cos(yaw)[:, None], np.sin(yaw)[:, None]
    x = positions[:, 0:1] + c * local[None, :, 0] - s * local[None, :, 1]
    y = positions[:, 1:2] + s * local[None, :, 0] + c * local[None, :, 1]
    return np.stack([x, y, np.zeros_like(x)], axis=-1)


def centre_in_view(camera: Camera, points: np.ndarray) -> np.ndarray:
    """(M,) bool: each (M, 3) point (an object centre, m) projects inside the image, in front of the camera.
    The one visibility rule: the generator's ``inside_camera_view`` (CLEVRER in/out events), perception's
    ``visible`` and the replay's ``visible`` (world.rollout) follow it."""
    pixels, depth = project_with_depth(camera, points)
    with np.errstate(invalid="ignore"):
        return (depth > 0) & (pixels[:, 0] >= -0.5) & (pixels[:, 0] <= camera.width - 0.5) \
            & (pixels[:, 1] >= -0.5) & (pixels[:, 1] <= camera.height - 0.5)


def view_events(visible: np.ndarray, active: np.ndarray) -> list[tuple[str, int, int]]:
    """CLEVRER-style view transitions from per-frame flags.

    visible, active: (T, N) bool. Returns (kind, body_index, frame) tuples with
    kind ``in`` (first visible frame after not being visible, frame >= 1) or
    ``out`` (first frame no longer visible while still active), sorted by frame.
    """
    if visible.shape[0] < 2:
        return []
    before, after = visible[:-1], visible[1:]
    entered = np.argwhere(after & ~before)
    left = np.argwhere(before & ~after & active[1:])
    events = [("in", int(n), int(f) + 1) for f, n in entered] + [("out", int(n), int(f) + 1) for f, n in left]
    return sorted(events, key=lambda e: (e[2], e[1], e[0]))


def look_at_camera(
    eye: tuple[float, float, float],
    target: tuple[float, float, float],
    width: int = 480,
    height: int = 320,
    vertical_fov_deg: float = 40.0,
) -> Camera:
    """A pinhole camera at ``eye`` (m) looking at ``target`` (m), world z up, no roll."""
    eye_v, target_v = np.asarray(eye, float), np.asarray(target, float)
    forward = target_v - eye_v
    if np.linalg.norm(forward) == 0:
        raise ValueError("look_at_camera: eye and target must differ")
    forward /= np.linalg.norm(forward)
    right = np.cross(forward, [0.0, 0.0, 1.0])
    if np.linalg.norm(right) < 1e-9:
        raise ValueError("look_at_camera: viewing direction must not be vertical")
    right /= np.linalg.norm(right)
    down = np.cross(forward, right)
    rotation = np.stack([right, down, forward], axis=1)  # columns: camera axes in world
    focal = 0.5 * height / math.tan(math.radians(vertical_fov_deg) / 2.0)
    return Camera(width=width, height=height, fx=focal, fy=focal, cx=width / 2.0, cy=height / 2.0,
                  position=tuple(eye_v), rotation=tuple(map(tuple, rotation)))
