"""Camera geometry for perception: pixel/metre Jacobian and primitive silhouettes.

Pure numpy; projection, rays and plane back-projection are world.camera's (one
owner of the pinhole model). Conventions as world.types.Camera: OpenCV pinhole (x right,
y down, z forward), ``rotation`` maps camera-frame vectors to the world,
pixel centres at integer coordinates. World z is up, the floor is z = 0.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from world.camera import backproject_to_height, pixel_rays, project  # the one owner of the pinhole model
from world.types import Camera


@dataclass(frozen=True)
class Box2D:
    """Integer pixel window [top, bottom) x [left, right) inside the image."""

    top: int
    bottom: int
    left: int
    right: int

    @property
    def empty(self) -> bool:
        return self.bottom <= self.top or self.right <= self.left

    @property
    def shape(self) -> tuple[int, int]:
        return (max(self.bottom - self.top, 0), max(self.right - self.left, 0))


def ground_jacobian(camera: Camera, point: np.ndarray, step: float = 1e-3) -> np.ndarray:
    """(2, 2) d(pixel u, v) / d(world x, y) at a 3D point (finite differences, one projection of 3 points)."""
    point = np.asarray(point, dtype=float)
    moved = np.repeat(point[None], 3, axis=0)  # the point, moved along x, moved along y
    moved[1, 0] += step
    moved[2, 1] += step
    pixels = project(camera, moved)
    return ((pixels[1:] - pixels[0]) / step).T


def primitive_window(camera: Camera, kind: str, centre: np.ndarray, size: float, margin: int = 2) -> Box2D:
    """Pixel window that holds the silhouette of a primitive of half-size ``size`` at ``centre``."""
    reach = size * (math.sqrt(2.0) if kind == "cube" else 1.0) + 1e-3
    offsets = np.array([[dx, dy, dz] for dx in (-reach, reach) for dy in (-reach, reach) for dz in (-size, size)])
    pixels = project(camera, np.asarray(centre, float)[None, :] + offsets)
    if np.any(~np.isfinite(pixels)):
        return Box2D(0, 0, 0, 0)
    left = max(int(math.floor(pixels[:, 0].min())) - margin, 0)
    right = min(int(math.ceil(pixels[:, 0].max())) + margin + 1, camera.width)
    top = max(int(math.floor(pixels[:, 1].min())) - margin, 0)
    bottom = min(int(math.ceil(pixels[:, 1].max())) + margin + 1, camera.height)
    return Box2D(top, bottom, left, right)


_CAMERA_ARRAYS_KEPT = 4  # cameras whose per-pixel arrays are kept (rays about 3.7 MB each at 480 x 320)
_CAMERA_ARRAYS: dict[tuple, dict] = {}  # camera parameters -> {what: read-only array(s)} (a video keeps its camera)


def _camera_key(camera: Camera) -> tuple:
    return (camera.width, camera.height, camera.fx, camera.fy, camera.cx, camera.cy,
            tuple(np.asarray(camera.position, float).ravel()), tuple(np.asarray(camera.rotation, float).ravel()))


def _per_camera(camera: Camera, what: str, compute):
    """``compute()``'s read-only array (or tuple of arrays) for this camera, computed once and kept for the last
    _CAMERA_ARRAYS_KEPT cameras."""
    key = _camera_key(camera)
    arrays = _CAMERA_ARRAYS.get(key)
    if arrays is None:
        if len(_CAMERA_ARRAYS) >= _CAMERA_ARRAYS_KEPT:
            _CAMERA_ARRAYS.pop(next(iter(_CAMERA_ARRAYS)))
        arrays = _CAMERA_ARRAYS[key] = {}
    if what not in arrays:
        value = compute()
        for array in value if isinstance(value, tuple) else (value,):
            array.flags.writeable = False
        arrays[what] = value
    return arrays[what]


def _pixel_grid(camera: Camera) -> tuple[np.ndarray, np.ndarray]:
    """(H, W) float u and v of every pixel centre."""
    v, u = np.mgrid[0:camera.height, 0:camera.width].astype(float)
    return u, v


def image_rays(camera: Camera) -> np.ndarray:
    """(H, W, 3) read-only world ray directions of every pixel (world.camera.pixel_rays), computed once per camera."""
    return _per_camera(camera, "rays", lambda: pixel_rays(camera, *_pixel_grid(camera)))


def floor_points(camera: Camera) -> np.ndarray:
    """(H, W, 2) read-only world xy (m) where each pixel's ray meets the floor z = 0 (world.camera.backproject_to_height);
    NaN at and above the horizon. Computed once per camera."""
    def compute() -> np.ndarray:
        u, v = _pixel_grid(camera)
        points = backproject_to_height(camera, np.stack([u.ravel(), v.ravel()], axis=1), 0.0)
        return np.ascontiguousarray(points[:, :2].reshape(camera.height, camera.width, 2))
    return _per_camera(camera, "floor", compute)


def floor_planes(camera: Camera) -> tuple[np.ndarray, np.ndarray]:
    """floor_points as two contiguous read-only (H, W) float32 planes, x and y (m): per-pixel tests over a window
    read them faster than the interleaved (H, W, 2) array."""
    points = floor_points(camera)
    return _per_camera(camera, "floor planes", lambda: (np.ascontiguousarray(points[..., 0], dtype=np.float32),
                                                        np.ascontiguousarray(points[..., 1], dtype=np.float32)))


def window_rays(camera: Camera, window: Box2D) -> np.ndarray:
    """(h, w, 3) world ray directions of a window's pixels (camera-depth parametrised), shared by ray casts over it:
    a view into image_rays (windows lie inside the image)."""
    return image_rays(camera)[window.top:window.bottom, window.left:window.right]


def ray_depths(camera: Camera, kind: str, centre: np.ndarray, size: float, yaw: float, window: Box2D,
               directions: np.ndarray | None = None) -> np.ndarray:
    """Ray-cast one primitive over a pixel window.

    kind: sphere (radius = size), cube (half side = size, yaw about +z),
    cylinder (radius = half height = size, axis +z). directions: window_rays(camera, window) when
    several casts share the window (e.g. cube yaws). Returns (h, w) float
    ray parameter of the first hit (proportional to camera depth), inf
    where the ray misses.
    """
    h, w = window.shape
    if h == 0 or w == 0:
        return np.full((h, w), np.inf)
    if directions is None:
        directions = window_rays(camera, window)  # (h, w, 3), camera-depth parametrised (z_cam = t)
    origin = np.asarray(camera.position) - np.asarray(centre, float)  # ray origin relative to the centre
    if kind == "sphere":
        return _hit_sphere(origin, directions, size)
    if kind == "cylinder":
        return _hit_cylinder(origin, directions, size, size)
    if kind == "cube":
        c, s = math.cos(yaw), math.sin(yaw)
        to_local = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])  # world -> body
        return _hit_box(to_local @ origin, directions @ to_local.T, size)
    raise ValueError(f"kind: expected sphere, cube or cylinder, got {kind!r}")


def _hit_sphere(origin: np.ndarray, d: np.ndarray, radius: float) -> np.ndarray:
    a = np.einsum("...i,...i->...", d, d)
    b = 2.0 * d @ origin
    c = float(origin @ origin) - radius * radius
    disc = b * b - 4 * a * c
    with np.errstate(invalid="ignore"):
        t = (-b - np.sqrt(disc)) / (2 * a)
    return np.where(disc >= 0, t, np.inf)


def _hit_cylinder(origin: np.ndarray, d: np.ndarray, radius: float, half_height: float) -> np.ndarray:
    # side: |(o + t d)_xy| = r, with |z| <= h
    a = d[..., 0] ** 2 + d[..., 1] ** 2
    b = 2.0 * (origin[0] * d[..., 0] + origin[1] * d[..., 1])
    c = origin[0] ** 2 + origin[1] ** 2 - radius * radius
    disc = b * b - 4 * a * c
    with np.errstate(invalid="ignore", divide="ignore"):
        t_side = (-b - np.sqrt(disc)) / (2 * a)
        z_side = origin[2] + t_side * d[..., 2]
        side_ok = (disc >= 0) & (np.abs(z_side) <= half_height)
        best = np.where(side_ok, t_side, np.inf)
        for cap in (half_height, -half_height):
            t_cap = (cap - origin[2]) / d[..., 2]
            x = origin[0] + t_cap * d[..., 0]
            y = origin[1] + t_cap * d[..., 1]
            cap_ok = (t_cap > 0) & (x * x + y * y <= radius * radius)
            best = np.where(cap_ok & (t_cap < best), t_cap, best)
    return best


def _hit_box(origin: np.ndarray, d: np.ndarray, half: float) -> np.ndarray:
    # slab method, one axis at a time: min/max over a trailing axis of length 3 is far slower in numpy
    t_near = np.full(d.shape[:-1], -np.inf)
    t_far = np.full(d.shape[:-1], np.inf)
    with np.errstate(divide="ignore", invalid="ignore"):
        for axis in range(3):
            component = d[..., axis]
            inv = 1.0 / np.where(np.abs(component) < 1e-12, 1e-12, component)
            t1 = (-half - origin[axis]) * inv
            t2 = (half - origin[axis]) * inv
            np.maximum(t_near, np.minimum(t1, t2), out=t_near)
            np.minimum(t_far, np.maximum(t1, t2), out=t_far)
    return np.where((t_near <= t_far) & (t_far > 0), t_near, np.inf)


def silhouette(camera: Camera, kind: str, centre: np.ndarray, size: float, yaw: float = 0.0) -> tuple[Box2D, np.ndarray]:
    """Window and (h, w) bool silhouette of a primitive (clipped to the image)."""
    window = primitive_window(camera, kind, centre, size)
    return window, np.isfinite(ray_depths(camera, kind, centre, size, yaw, window))


UPWARD_NORMAL_Z = 0.9  # a surface whose normal is this close to vertical faces up (a sphere's cap within 26 deg)
TOP_FACE_TOLERANCE = 1e-6  # m: a cube's or cylinder's first hit this close to its top plane is on its top face


def upward_surface(camera: Camera, kind: str, centre: np.ndarray, size: float, depths: np.ndarray, window: Box2D,
                   directions: np.ndarray | None = None) -> np.ndarray:
    """(h, w) bool: the window's pixels whose first hit (depths: ray_depths over ``window``) lies on an upward
    surface of the primitive: a cube's or cylinder's top face, a sphere's cap (normal z >= UPWARD_NORMAL_Z).
    Such a surface gets the light the floor gets, so a paint like the floor's looks like the floor."""
    if directions is None:
        directions = window_rays(camera, window)
    height_above_centre = (float(camera.position[2]) - float(np.asarray(centre)[2])) + depths * directions[..., 2]
    lowest = UPWARD_NORMAL_Z * size if kind == "sphere" else size - TOP_FACE_TOLERANCE  # a sphere's normal z is height / radius
    with np.errstate(invalid="ignore"):
        return np.isfinite(depths) & (height_above_centre >= lowest)


def silhouette_and_top(camera: Camera, kind: str, centre: np.ndarray, size: float, yaw: float = 0.0,
                       with_top: bool = True) -> tuple[Box2D, np.ndarray, np.ndarray | None]:
    """Window, (h, w) bool silhouette and (h, w) bool upward surface (upward_surface) of a primitive, one ray cast;
    the upward surface None when not ``with_top``."""
    if not with_top:
        window, sil = silhouette(camera, kind, centre, size, yaw)
        return window, sil, None
    window = primitive_window(camera, kind, centre, size)
    directions = window_rays(camera, window)
    depths = ray_depths(camera, kind, centre, size, yaw, window, directions)
    return window, np.isfinite(depths), upward_surface(camera, kind, centre, size, depths, window, directions)
