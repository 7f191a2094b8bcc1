"""Closed-form 3D motion laws, exact event roots and impact responses.

Every segment between events has constant acceleration, so a body's centre
follows p(tau) = p0 + v0 tau + a tau^2 / 2 (ballistic flight: a = (0, 0, -g);
sliding on a face with unit normal n and Coulomb coefficient mu, velocity
along the face's fall line or on a level face: a = g_t - mu g n_z v/|v|, with
g_t the in-plane part of gravity; rest: a = 0). Body-surface events are the
roots of quadratics; body-body gaps are piecewise polynomial and their first
zero is bracketed on a 1 ms grid and refined by Brent's method.
Shapes: positions, velocities and accelerations are (3,) arrays, metres and seconds.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.optimize import brentq

from world.scene3d.types import Body3D, Face, StaticBox

SUPPORT_SPEED = 0.15  # m/s: a rebound slower than this ends the bounce sequence (the body then slides)
SURFACE_TOLERANCE = 0.003  # m: a centre this close to its contact distance counts as touching the surface
ZONE_TOUCH_TOLERANCE = 0.005  # m: a body within this distance of a zone patch touches it (truth and engine)
ROOT_GRID = 1e-3  # s: sampling step that brackets body-body gap roots
SPHERE_ROLLING_SHARE = 2.0 / 7.0  # share of the tangential speed a sphere loses when it starts to roll


def position_at(p0: np.ndarray, v0: np.ndarray, accel: np.ndarray, tau) -> np.ndarray:
    """Centre at times tau (scalar or (K,)) after the segment start: (3,) or (K, 3)."""
    tau = np.asarray(tau, dtype=float)
    return p0 + np.multiply.outer(tau, v0) + 0.5 * np.multiply.outer(tau * tau, accel)


def velocity_at(v0: np.ndarray, accel: np.ndarray, tau) -> np.ndarray:
    tau = np.asarray(tau, dtype=float)
    return v0 + np.multiply.outer(tau, accel)


def quadratic_roots(c2: float, c1: float, c0: float) -> list[float]:
    """Real roots of c2 x^2 + c1 x + c0, ascending (numerically stable form)."""
    scale = max(abs(c2), abs(c1), abs(c0), 1e-300)
    if abs(c2) < 1e-12 * scale:
        return [] if abs(c1) < 1e-15 * scale else [-c0 / c1]
    disc = c1 * c1 - 4.0 * c2 * c0
    if disc < 0:
        return []
    q = -0.5 * (c1 + math.copysign(math.sqrt(disc), c1))
    roots = [q / c2] + ([c0 / q] if q != 0 else [])
    return sorted(roots)


def sliding_acceleration(normal: np.ndarray, velocity: np.ndarray, friction: float, gravity: float) -> np.ndarray:
    """Acceleration (3,) of a body sliding on a face with outward unit ``normal``.

    In-plane gravity minus Coulomb friction mu g n_z against the velocity; a body
    at rest stays at rest when mu >= tan(slope), else it starts down the fall line.
    """
    g_vec = np.array([0.0, 0.0, -gravity])
    g_tangent = g_vec - np.dot(g_vec, normal) * normal
    normal_load = gravity * normal[2]
    speed = np.linalg.norm(velocity)
    if speed > 1e-9:
        return g_tangent - friction * normal_load * velocity / speed
    slope_pull = np.linalg.norm(g_tangent)
    if slope_pull <= friction * normal_load + 1e-12:
        return np.zeros(3)
    return g_tangent * (1.0 - friction * normal_load / slope_pull)


def stop_time(velocity: np.ndarray, accel: np.ndarray) -> float | None:
    """Time (s) at which a sliding body's speed along its direction of motion reaches zero, or None."""
    speed = np.linalg.norm(velocity)
    if speed < 1e-12:
        return None
    along = float(np.dot(accel, velocity) / speed)
    return speed / -along if along < -1e-12 else None


def face_coordinates(face: Face, points: np.ndarray) -> np.ndarray:
    """(..., 3) points -> (..., 3) (u, v, signed distance along the normal) relative to the face centre."""
    rel = np.asarray(points) - np.asarray(face.center)
    return np.stack([rel @ np.asarray(face.axis_u), rel @ np.asarray(face.axis_v), rel @ np.asarray(face.normal)], axis=-1)


def plane_contact_time(p0, v0, accel, face: Face, offset: float, tau_max: float) -> float | None:
    """First time in (0, tau_max] the centre reaches distance ``offset`` from the face plane while
    approaching it, with its projection inside the face rectangle; None if it does not.

    The signed distance is the quadratic n.(p(tau) - c) - offset: its roots are the candidates.
    """
    normal, center = np.asarray(face.normal), np.asarray(face.center)
    d0 = float(np.dot(p0 - center, normal)) - offset
    if d0 < -SURFACE_TOLERANCE:
        return None  # already behind the plane (the body is beside or under this face)
    c1, c2 = float(np.dot(v0, normal)), 0.5 * float(np.dot(accel, normal))
    for tau in quadratic_roots(c2, c1, d0):
        if tau <= 1e-9 or tau > tau_max:
            continue
        if c1 + 2.0 * c2 * tau >= 0:
            continue  # leaving the plane, not hitting it
        u, v, _ = face_coordinates(face, position_at(p0, v0, accel, tau))
        if abs(u) <= face.half_u and abs(v) <= face.half_v:
            return tau
    return None


def leave_face_time(p0, v0, accel, face: Face, tau_max: float) -> float | None:
    """First time in (0, tau_max] the centre's projection leaves the face rectangle, or None."""
    best = None
    for axis, half in ((np.asarray(face.axis_u), face.half_u), (np.asarray(face.axis_v), face.half_v)):
        c0 = float(np.dot(p0 - np.asarray(face.center), axis))
        c1, c2 = float(np.dot(v0, axis)), 0.5 * float(np.dot(accel, axis))
        for bound in (half, -half):
            for tau in quadratic_roots(c2, c1, c0 - bound):
                slope = c1 + 2.0 * c2 * tau
                if 1e-9 < tau <= tau_max and slope * bound > 0 and (best is None or tau < best):
                    best = tau
    return best


def bounce_velocity(velocity: np.ndarray, normal: np.ndarray, restitution: float, friction: float, shape: str) -> np.ndarray:
    """Velocity (3,) after an impact on a static surface with outward unit ``normal``.

    Normal part reversed and scaled by e; tangential part reduced by the Coulomb
    impulse mu (1 + e) |v_n|, at most to sticking (a cube: all of it; a sphere:
    2/7 of it, when it starts rolling). Spin is not tracked.
    """
    v_n = float(np.dot(velocity, normal))
    if v_n >= 0:
        return velocity.copy()
    tangent = velocity - v_n * normal
    speed_t = np.linalg.norm(tangent)
    cap = speed_t * (SPHERE_ROLLING_SHARE if shape == "sphere" else 1.0)
    loss = min(friction * (1.0 + restitution) * -v_n, cap)
    new_tangent = tangent * (1.0 - loss / speed_t) if speed_t > 1e-12 else tangent
    return new_tangent - restitution * v_n * normal


def _box_frame(box: StaticBox, points: np.ndarray) -> np.ndarray:
    return (np.asarray(points) - np.asarray(box.center)) @ box.rotation


def gap_to_static(body: Body3D, box: StaticBox, centres: np.ndarray) -> np.ndarray:
    """(K,) separation (m) between a body at centres (K, 3) and a static box; <= 0 when touching.

    Cubes are taken aligned with the box frame (a Chebyshev gap, zero exactly at contact);
    spheres use the Euclidean distance from the centre to the box.
    """
    local = _box_frame(box, np.atleast_2d(centres))
    excess = np.abs(local) - np.asarray(box.half_extents)
    if body.shape == "cube":
        return excess.max(axis=1) - body.half_size
    outside = np.linalg.norm(np.maximum(excess, 0.0), axis=1)
    inside = np.minimum(excess.max(axis=1), 0.0)
    return outside + inside - body.half_size


def gap_between(a: Body3D, b: Body3D, pa: np.ndarray, pb: np.ndarray) -> np.ndarray:
    """(K,) separation (m) of two bodies at centres pa, pb (K, 3); <= 0 when touching. Cubes world-aligned."""
    delta = np.atleast_2d(pb) - np.atleast_2d(pa)
    if a.shape == "sphere" and b.shape == "sphere":
        return np.linalg.norm(delta, axis=1) - a.half_size - b.half_size
    if a.shape == "cube" and b.shape == "cube":
        return (np.abs(delta) - (a.half_size + b.half_size)).max(axis=1)
    sphere_first = a.shape == "sphere"
    radius = a.half_size if sphere_first else b.half_size
    half = b.half_size if sphere_first else a.half_size
    excess = np.abs(delta) - half
    return np.linalg.norm(np.maximum(excess, 0.0), axis=1) + np.minimum(excess.max(axis=1), 0.0) - radius


def contact_normal(a: Body3D, b: Body3D, pa: np.ndarray, pb: np.ndarray) -> np.ndarray:
    """Unit normal (3,) from a towards b at contact."""
    delta = np.asarray(pb) - np.asarray(pa)
    if a.shape == "cube" and b.shape == "cube":
        axis = int(np.argmax(np.abs(delta) - (a.half_size + b.half_size)))
        normal = np.zeros(3)
        normal[axis] = math.copysign(1.0, delta[axis])
        return normal
    if a.shape == "sphere" and b.shape == "sphere":
        return delta / max(np.linalg.norm(delta), 1e-12)
    # sphere-cube: from the closest point of the cube to the sphere centre
    sphere_first = a.shape == "sphere"
    rel = -delta if sphere_first else delta  # sphere centre relative to cube centre
    half = b.half_size if sphere_first else a.half_size
    closest = np.clip(rel, -half, half)
    direction = rel - closest
    if np.linalg.norm(direction) < 1e-12:
        axis = int(np.argmax(np.abs(rel)))
        direction = np.zeros(3)
        direction[axis] = math.copysign(1.0, rel[axis])
    direction = direction / np.linalg.norm(direction)  # cube -> sphere
    return -direction if sphere_first else direction


def first_gap_root(gap, tau_max: float, tolerance: float = 0.0) -> float | None:
    """First time in [0, tau_max] a gap function gap(tau_array) -> (K,) falls to ``tolerance``.

    Bracketed on a ROOT_GRID grid, refined by Brent's method; 0.0 when already touching.
    """
    if tau_max <= 0:
        return None
    grid = np.linspace(0.0, tau_max, max(2, int(math.ceil(tau_max / ROOT_GRID)) + 1))
    values = gap(grid) - tolerance
    if values[0] <= 0:
        return 0.0
    hits = np.nonzero(values <= 0)[0]
    if len(hits) == 0:
        return None
    k = int(hits[0])
    return float(brentq(lambda t: float(gap(np.array([t]))[0] - tolerance), grid[k - 1], grid[k], xtol=1e-10))


def pair_impulse_velocities(va: np.ndarray, vb: np.ndarray, ma: float, mb: float, normal: np.ndarray,
                            restitution: float) -> tuple[np.ndarray, np.ndarray]:
    """Velocities after a frictionless impact of a and b along ``normal`` (a -> b), masses kg.

    j = (1 + e) (v_a - v_b).n / (1/m_a + 1/m_b); nothing happens if they separate.
    """
    closing = float(np.dot(va - vb, normal))
    if closing <= 0:
        return va.copy(), vb.copy()
    j = (1.0 + restitution) * closing / (1.0 / ma + 1.0 / mb)
    return va - j / ma * normal, vb + j / mb * normal
