"""Pairwise contact: exact footprint distances and the earliest approaching contact time.

Bodies collide through their footprints on the support plane: spheres and
cylinders are circles, cubes are squares rotated by their yaw. Heights are
not compared (tabletop scenes: every body touches the plane).

* circle-circle: the relative position of two quadratic-in-time flows is a
  quadratic vector polynomial, so ``|d(t)|^2 - R^2`` is a quartic; its real
  roots in the window are isolated exactly by the roots of its derivatives
  (down to a closed-form quadratic) and refined by bracketed Newton to ~1e-15
  relative (``real_roots``). Exact up to floating point.
* anything with a square: conservative advancement on the exact signed
  distance (never steps past a contact), then bisection once a step would
  penetrate. Tolerance: the returned time has a gap in ``[0, CA_TOL]``, or
  is within ``BISECT_TIME_TOL`` of the exact root.

A contact counts only when the bodies approach along the contact normal
(``(v_i - v_j) . n < -APPROACH_TOL``), or touch with no normal speed while
their relative acceleration closes them (a pushing contact), so tangential
grazes, separating roots and resting contacts create no events.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

CIRCLE, SQUARE = "circle", "square"

TOUCH_TOL = 1e-7  # m: a gap this small counts as touching (for immediate contacts)
CA_TOL = 1e-9  # m: conservative advancement stops when the gap is this small
APPROACH_TOL = 1e-9  # m/s: normal approach speed below this is a graze, not a collision
PUSH_ACCEL_TOL = 1e-9  # m/s^2: touching, no approach speed, but closing faster than this = pushing contact
MIN_CA_STEP = 1e-4  # s: smallest advancement step while overlapping (no touch can start sooner)
# s: the smallest step near a touch. Closer than MIN_CA_STEP x closing speed, the search steps by
# the corners' quadratic clearance bound (``clearance_step``), which never passes a touch; this
# floor only keeps a tangential graze (zero clearance, zero normal speed) from stalling. A corner
# can sweep in by at most its closing speed x this floor (~1e-6 m at 10 m/s).
MIN_CLEARANCE_STEP = 1e-7
CLEARANCE_WINDOW = 1e-2  # s: the window over which clearance_step bounds the corners' accelerations
BISECT_TIME_TOL = 1e-12  # s
MAX_CA_ITERATIONS = 200  # then the pair is re-checked from where it stopped (Contact.normal None)
# m: a square's boundary within this depth of its deepest point along the normal
# carries the contact (the patch of a face pressed flat). Our choice, not measured:
# it makes the patch move continuously as a face tilts away from its partner's.
PATCH_DEPTH = 1e-3
# Passes of stopping impulses over a patch's centre and ends after an impact: each pass removes
# energy; two points (the ends) settle within a few (the rest is below rounding at contact speeds).
PATCH_END_PASSES = 4
# kg m^2: floor of a yaw inertia in the impulse. An edited mass so small that mass x inertia-per-mass
# underflows to 0 would divide by zero; at the floor the body still takes (almost) no impulse.
MIN_YAW_INERTIA = 2.2250738585072014e-308  # the smallest normal float


@dataclass(frozen=True)
class Footprint:
    """A body's outline on the plane: kind circle (size = radius, m) or square (size = half side, m)."""

    kind: str
    size: float

    @property
    def bounding_radius(self) -> float:
        return self.size * math.sqrt(2.0) if self.kind == SQUARE else self.size


@dataclass(frozen=True)
class PlanarMotion:
    """A body's horizontal quadratic flow relative to a reference time (tau = 0).

    position, velocity, acceleration: (2,) m, m/s, m/s^2 at tau = 0.
    yaw (rad), yaw_rate (rad/s), yaw_accel (rad/s^2) at tau = 0.
    """

    footprint: Footprint
    position: tuple[float, float]
    velocity: tuple[float, float]
    acceleration: tuple[float, float]
    yaw: float = 0.0
    yaw_rate: float = 0.0
    yaw_accel: float = 0.0

    def at(self, tau: float) -> tuple[float, float, float, float, float]:
        """x, y (m), yaw (rad), vx, vy (m/s) at tau (s)."""
        p, v, a = self.position, self.velocity, self.acceleration
        half = 0.5 * tau * tau
        return (p[0] + v[0] * tau + a[0] * half, p[1] + v[1] * tau + a[1] * half,
                self.yaw + self.yaw_rate * tau + self.yaw_accel * half,
                v[0] + a[0] * tau, v[1] + a[1] * tau)


@dataclass(frozen=True)
class Contact:
    """A predicted contact: tau (s after the reference time), normal (2,) unit from j to i, point (2,) m.

    ``normal`` None means no contact was found up to tau, but the search budget
    ran out: the caller must predict again from tau (no contact is skipped).
    """

    tau: float
    normal: tuple[float, float] | None
    point: tuple[float, float]


# --------------------------------------------------------------------------- distances

def point_square_distance(px: float, py: float, cx: float, cy: float, yaw: float, half: float) -> tuple[float, float, float]:
    """Signed distance (m) from a point to a square, and the unit outward gradient (gx, gy).

    Negative inside. The gradient points from the square towards the point.
    """
    c, s = math.cos(yaw), math.sin(yaw)
    dx, dy = px - cx, py - cy
    qx, qy = c * dx + s * dy, -s * dx + c * dy
    ex, ey = abs(qx) - half, abs(qy) - half
    if ex > 0.0 or ey > 0.0:
        ox, oy = max(ex, 0.0), max(ey, 0.0)
        dist = math.hypot(ox, oy)
        lx, ly = math.copysign(ox, qx) / dist, math.copysign(oy, qy) / dist
    elif ex > ey:
        dist, lx, ly = ex, math.copysign(1.0, qx), 0.0
    else:
        dist, lx, ly = ey, 0.0, math.copysign(1.0, qy)
    return dist, c * lx - s * ly, s * lx + c * ly


def _square_corners(cx: float, cy: float, yaw: float, half: float) -> list[tuple[float, float]]:
    c, s = math.cos(yaw) * half, math.sin(yaw) * half
    return [(cx + c - s, cy + s + c), (cx - c - s, cy - s + c), (cx - c + s, cy - s - c), (cx + c + s, cy + s - c)]


def footprint_distance(
    fi: Footprint, xi: float, yi: float, yawi: float,
    fj: Footprint, xj: float, yj: float, yawj: float,
) -> tuple[float, tuple[float, float], tuple[float, float]]:
    """Exact signed distance (m) between two footprints, the unit normal from j to i, and a contact point.

    Negative when they overlap (then the magnitude is the penetration depth,
    exact for circles, the minimum separating-axis overlap for squares).
    """
    if fi.kind == CIRCLE and fj.kind == CIRCLE:
        dx, dy = xi - xj, yi - yj
        dist = math.hypot(dx, dy)
        nx, ny = (dx / dist, dy / dist) if dist > 0 else (1.0, 0.0)
        gap = dist - fi.size - fj.size
        return gap, (nx, ny), (xj + nx * (fj.size + 0.5 * gap), yj + ny * (fj.size + 0.5 * gap))
    if fi.kind == CIRCLE:  # circle i, square j
        sd, gx, gy = point_square_distance(xi, yi, xj, yj, yawj, fj.size)
        gap = sd - fi.size
        return gap, (gx, gy), (xi - gx * (fi.size + 0.5 * gap), yi - gy * (fi.size + 0.5 * gap))
    if fj.kind == CIRCLE:  # square i, circle j
        sd, gx, gy = point_square_distance(xj, yj, xi, yi, yawi, fi.size)
        gap = sd - fj.size
        return gap, (-gx, -gy), (xj - gx * (fj.size + 0.5 * gap), yj - gy * (fj.size + 0.5 * gap))
    # square-square: separating axes first (also gives the overlap depth).
    dx, dy = xi - xj, yi - yj
    axes_i = ((math.cos(yawi), math.sin(yawi)), (-math.sin(yawi), math.cos(yawi)))
    axes_j = ((math.cos(yawj), math.sin(yawj)), (-math.sin(yawj), math.cos(yawj)))
    best_sep, best_axis = -math.inf, (1.0, 0.0)
    for ux, uy in axes_i + axes_j:
        extent_i = fi.size * (abs(ux * axes_i[0][0] + uy * axes_i[0][1]) + abs(ux * axes_i[1][0] + uy * axes_i[1][1]))
        extent_j = fj.size * (abs(ux * axes_j[0][0] + uy * axes_j[0][1]) + abs(ux * axes_j[1][0] + uy * axes_j[1][1]))
        along = ux * dx + uy * dy
        sep = abs(along) - extent_i - extent_j
        if sep > best_sep:
            sign = 1.0 if along >= 0 else -1.0
            best_sep, best_axis = sep, (sign * ux, sign * uy)
    if best_sep <= 0.0:
        # Overlapping (or exactly touching): depth and normal of the best separating axis.
        return best_sep, best_axis, (0.5 * (xi + xj), 0.5 * (yi + yj))
    # Separated convex polygons: the closest pair always involves a corner of one of them.
    best = (math.inf, best_axis, (0.0, 0.0))
    for cx, cy in _square_corners(xi, yi, yawi, fi.size):
        sd, gx, gy = point_square_distance(cx, cy, xj, yj, yawj, fj.size)
        if sd < best[0]:
            best = (sd, (gx, gy), (cx - 0.5 * sd * gx, cy - 0.5 * sd * gy))
    for cx, cy in _square_corners(xj, yj, yawj, fj.size):
        sd, gx, gy = point_square_distance(cx, cy, xi, yi, yawi, fi.size)
        if sd < best[0]:
            best = (sd, (-gx, -gy), (cx - 0.5 * sd * gx, cy - 0.5 * sd * gy))
    return best


def _support_interval(footprint: Footprint, cx: float, cy: float, yaw: float,
                      direction: tuple[float, float], point: tuple[float, float]) -> tuple[float, float]:
    """Tangential extent (lo, hi) of the part of a footprint's boundary that carries a contact.

    direction: (2,) unit, pointing from the footprint towards its partner;
    the part is the boundary within ``PATCH_DEPTH`` of the footprint's
    furthest point along it. Measured along ``t = (-d_y, d_x)`` from ``point`` (m).
    A circle touches at one point; a square along a clipped piece of the two
    edges at its furthest corner (a whole edge when that edge faces the partner).
    """
    dx, dy = direction
    tx, ty = -dy, dx
    if footprint.kind == CIRCLE:
        along = (cx - point[0]) * tx + (cy - point[1]) * ty
        return along, along
    corners = _square_corners(cx, cy, yaw, footprint.size)
    heights = [(x - point[0]) * dx + (y - point[1]) * dy for x, y in corners]
    top = max(range(4), key=lambda k: heights[k])
    ax, ay = corners[top]
    ends = [(ax - point[0]) * tx + (ay - point[1]) * ty]
    for neighbour in ((top + 1) % 4, (top + 3) % 4):
        drop = heights[top] - heights[neighbour]
        share = 1.0 if drop <= PATCH_DEPTH else PATCH_DEPTH / drop
        bx, by = corners[neighbour]
        ends.append((ax + share * (bx - ax) - point[0]) * tx + (ay + share * (by - ay) - point[1]) * ty)
    return min(ends), max(ends)


def contact_patch(
    fi: Footprint, xi: float, yi: float, yawi: float,
    fj: Footprint, xj: float, yj: float, yawj: float,
    normal: tuple[float, float], point: tuple[float, float],
) -> tuple[tuple[float, float], tuple[tuple[float, float], tuple[float, float]]]:
    """Centre (2,) m of the contact patch of two touching footprints (where the normal impulse
    acts) and its two ends ((2,), (2,)) m (both the centre for a point contact).

    normal: (2,) unit from j to i; point: a contact point (``footprint_distance``).
    The patch is the overlap, along the tangent, of the parts of both
    boundaries that carry the contact (``_support_interval``): a point for a
    corner or a circle, a segment for two faces pressed flat (its middle is
    the resultant of a uniform pressure). Falls back to ``point`` when the
    parts do not overlap.
    """
    lo_i, hi_i = _support_interval(fi, xi, yi, yawi, (-normal[0], -normal[1]), point)
    lo_j, hi_j = _support_interval(fj, xj, yj, yawj, normal, point)
    # i's tangent is -t, j's is t: flip i's interval onto j's axis.
    lo, hi = max(-hi_i, lo_j), min(-lo_i, hi_j)
    if lo > hi:
        return point, (point, point)

    def along(offset: float) -> tuple[float, float]:
        return point[0] - normal[1] * offset, point[1] + normal[0] * offset

    return along(0.5 * (lo + hi)), (along(lo), along(hi))


def contact_patch_centre(
    fi: Footprint, xi: float, yi: float, yawi: float,
    fj: Footprint, xj: float, yj: float, yawj: float,
    normal: tuple[float, float], point: tuple[float, float],
) -> tuple[float, float]:
    """Centre (2,) m of the contact patch (``contact_patch``): where the normal impulse acts."""
    return contact_patch(fi, xi, yi, yawi, fj, xj, yj, yawj, normal, point)[0]


# --------------------------------------------------------------------------- contact times

def _quartic_gap_coefficients(d0, dv, da, radius_sum):
    """Coefficients (highest first) of |d0 + dv t + da t^2 / 2|^2 - R^2."""
    a4 = 0.25 * (da[0] * da[0] + da[1] * da[1])
    a3 = dv[0] * da[0] + dv[1] * da[1]
    a2 = dv[0] * dv[0] + dv[1] * dv[1] + d0[0] * da[0] + d0[1] * da[1]
    a1 = 2.0 * (d0[0] * dv[0] + d0[1] * dv[1])
    a0 = d0[0] * d0[0] + d0[1] * d0[1] - radius_sum * radius_sum
    return [a4, a3, a2, a1, a0]


def circle_contact_time(
    d0: tuple[float, float], dv: tuple[float, float], da: tuple[float, float],
    radius_sum: float, tau_max: float,
) -> float | None:
    """Earliest tau in [0, tau_max] (s) where two circles touch while approaching, or None.

    d0, dv, da: (2,) relative position (m), velocity (m/s), acceleration (m/s^2)
    of body i minus body j at tau = 0. radius_sum: r_i + r_j (m).
    """
    dist0 = math.hypot(d0[0], d0[1])
    radial_speed0 = (d0[0] * dv[0] + d0[1] * dv[1]) / dist0 if dist0 > 0 else 0.0
    if dist0 - radius_sum <= TOUCH_TOL:
        # Touching (or overlapping) now: a contact if they approach right now, or push
        # (no normal speed but a closing relative acceleration, e.g. a faster-braking body ahead).
        radial_accel0 = ((dv[0] * dv[0] + dv[1] * dv[1] + d0[0] * da[0] + d0[1] * da[1]) / dist0
                         - radial_speed0 * radial_speed0 / dist0) if dist0 > 0 else 0.0
        if closing(radial_speed0, radial_accel0):
            return 0.0
        return _next_entry_root(d0, dv, da, radius_sum, tau_max, after=0.0)
    # Cheap rejection: the gap cannot close within the window.
    speed_bound = math.hypot(dv[0], dv[1]) * tau_max + 0.5 * math.hypot(da[0], da[1]) * tau_max * tau_max
    if dist0 - radius_sum > speed_bound:
        return None
    return _next_entry_root(d0, dv, da, radius_sum, tau_max, after=0.0)


def closing(normal_speed: float, normal_accel: float) -> bool:
    """Whether two touching bodies close in: relative normal speed (m/s, < 0 approaching)
    and acceleration (m/s^2) along the contact normal.

    True when they approach, or when the relative acceleration closes them before
    they open a gap larger than TOUCH_TOL (a pushing contact, e.g. a faster-braking
    body ahead, or the rounding-level bounce of e ~ 0).
    """
    if normal_speed < -APPROACH_TOL:
        return True
    if normal_accel >= -PUSH_ACCEL_TOL:
        return False
    if normal_speed <= APPROACH_TOL:
        return True
    return normal_speed * normal_speed / (-2.0 * normal_accel) <= TOUCH_TOL


def _horner(coeffs: list[float], x: float) -> float:
    value = 0.0
    for c in coeffs:
        value = value * x + c
    return value


def _trim(coeffs: list[float]) -> list[float]:
    """Drop leading coefficients that vanish relative to the largest (lower the degree)."""
    scale = max((abs(c) for c in coeffs), default=0.0)
    if scale == 0.0:
        return []
    start = 0
    while start < len(coeffs) and abs(coeffs[start]) <= 1e-14 * scale:
        start += 1
    return coeffs[start:]


def _bracketed_root(coeffs: list[float], deriv: list[float], lo: float, hi: float, f_lo: float) -> float:
    """The single root of a polynomial that changes sign on [lo, hi]: Newton kept inside the bracket."""
    x = 0.5 * (lo + hi)
    for _ in range(200):
        fx = _horner(coeffs, x)
        if fx == 0.0:
            return x
        if (fx < 0.0) == (f_lo < 0.0):
            lo, f_lo = x, fx
        else:
            hi = x
        slope = _horner(deriv, x)
        step = x - fx / slope if slope != 0.0 else 0.5 * (lo + hi)
        if not lo < step < hi:
            step = 0.5 * (lo + hi)
        if abs(step - x) <= 1e-15 * (1.0 + abs(x)) or hi - lo <= 1e-15 * (1.0 + abs(x)):
            return step
        x = step
    return x


def real_roots(coeffs: list[float], lo: float, hi: float) -> list[float]:
    """All real roots (sorted) of a polynomial (coefficients highest first) in [lo, hi].

    Exact isolation: the real roots of the derivative split [lo, hi] into monotone
    pieces (recursively, down to the closed-form quadratic); each piece with a sign
    change holds exactly one root, found by bracketed Newton to ~1e-15 relative.
    Roots of even multiplicity (tangencies, no sign change) are not reported.
    """
    coeffs = _trim(list(coeffs))
    degree = len(coeffs) - 1
    if degree <= 0 or hi < lo:
        return []
    if degree == 1:
        root = -coeffs[1] / coeffs[0]
        return [root] if lo <= root <= hi else []
    if degree == 2:
        a, b, c = coeffs
        disc = b * b - 4.0 * a * c
        if disc <= 0.0:
            return []  # no real root, or a double root (tangency)
        q = -0.5 * (b + math.copysign(math.sqrt(disc), b))
        roots = sorted({q / a, c / q} if q != 0.0 else {0.0})
        return [r for r in roots if lo <= r <= hi]
    deriv = [c * (degree - i) for i, c in enumerate(coeffs[:-1])]
    points = [lo] + [r for r in real_roots(deriv, lo, hi) if lo < r < hi] + [hi]
    roots: list[float] = []
    f_a = _horner(coeffs, lo)
    for a, b in zip(points, points[1:]):
        f_b = _horner(coeffs, b)
        if f_a == 0.0:
            roots.append(a)
        elif f_a * f_b < 0.0:
            roots.append(_bracketed_root(coeffs, deriv, a, b, f_a))
        f_a = f_b
    if f_a == 0.0:
        roots.append(hi)
    return sorted(set(roots))


def _next_entry_root(d0, dv, da, radius_sum, tau_max, after):
    coeffs = _quartic_gap_coefficients(d0, dv, da, radius_sum)
    for tau in real_roots(coeffs, after, tau_max):
        dx = d0[0] + dv[0] * tau + 0.5 * da[0] * tau * tau
        dy = d0[1] + dv[1] * tau + 0.5 * da[1] * tau * tau
        vx, vy = dv[0] + da[0] * tau, dv[1] + da[1] * tau
        dist = math.hypot(dx, dy)
        if dist > 0 and (dx * vx + dy * vy) / dist < -APPROACH_TOL:
            return float(tau)
    return None


def predict_contact(mi: PlanarMotion, mj: PlanarMotion, tau_max: float, tau_flow_end: float | None = None) -> Contact | None:
    """Earliest approaching contact of two footprints within [0, tau_max] (s), or None.

    tau_flow_end (s, >= tau_max): where the two quadratic flows themselves end
    (a stop or landing). Roots are isolated on [0, tau_flow_end] and then cut at
    tau_max, so a contact time does not depend on unrelated window limits
    (horizon, a removal) down to the last bit.
    """
    if tau_max < 0:
        return None
    search_end = tau_max if tau_flow_end is None or not math.isfinite(tau_flow_end) else max(tau_flow_end, tau_max)
    d0 = (mi.position[0] - mj.position[0], mi.position[1] - mj.position[1])
    dv = (mi.velocity[0] - mj.velocity[0], mi.velocity[1] - mj.velocity[1])
    da = (mi.acceleration[0] - mj.acceleration[0], mi.acceleration[1] - mj.acceleration[1])
    fi, fj = mi.footprint, mj.footprint
    if not _paths_come_close(mi, mj, tau_max, fi.bounding_radius + fj.bounding_radius + TOUCH_TOL):
        return None
    if fi.kind == CIRCLE and fj.kind == CIRCLE:
        tau = circle_contact_time(d0, dv, da, fi.size + fj.size, search_end)
        if tau is None or tau > tau_max:
            return None
        xi, yi, yawi, _, _ = mi.at(tau)
        xj, yj, yawj, _, _ = mj.at(tau)
        _, normal, point = footprint_distance(fi, xi, yi, yawi, fj, xj, yj, yawj)
        return Contact(tau, normal, point)
    contact = _swept_square_contact(mi, mj, d0, dv, da, search_end)
    return contact if contact is not None and contact.tau <= tau_max else None


def _straight(m: PlanarMotion) -> bool:
    """Whether the flow's acceleration is against its velocity (or zero): a straight path
    that never speeds up. A skidding sphere's acceleration opposes its slip, not its velocity."""
    (vx, vy), (ax, ay) = m.velocity, m.acceleration
    accel = math.hypot(ax, ay)
    if accel == 0.0:
        return True
    speed = math.hypot(vx, vy)
    return speed > 0.0 and ax * vx + ay * vy < 0.0 and abs(vx * ay - vy * ax) <= 1e-12 * speed * accel


def _speed_bound(m: PlanarMotion, tau_max: float) -> float:
    """Upper bound (m/s) of the body's speed within [0, tau_max]."""
    speed = math.hypot(*m.velocity)
    return speed if _straight(m) else speed + math.hypot(*m.acceleration) * tau_max


def _path_segment(m: PlanarMotion, tau_max: float) -> tuple[float, float, float, float]:
    """Start and end (x0, y0, x1, y1) of the straight path a body covers within [0, tau_max].

    Every flow moves in a straight line (acceleration parallel to velocity);
    within one window a sliding body never passes its stop.
    """
    (x, y), (vx, vy), (ax, ay) = m.position, m.velocity, m.acceleration
    speed = math.hypot(vx, vy)
    if speed == 0.0:
        return x, y, x, y
    along = (ax * vx + ay * vy) / speed  # signed acceleration along the motion
    duration = min(tau_max, speed / -along) if along < 0.0 else tau_max  # no travel past a stop
    distance = speed * duration + 0.5 * along * duration * duration
    return x, y, x + vx / speed * distance, y + vy / speed * distance


def _point_segment_distance(px, py, x0, y0, x1, y1) -> float:
    dx, dy = x1 - x0, y1 - y0
    length2 = dx * dx + dy * dy
    u = 0.0 if length2 == 0.0 else min(max(((px - x0) * dx + (py - y0) * dy) / length2, 0.0), 1.0)
    return math.hypot(px - x0 - u * dx, py - y0 - u * dy)


def _segments_distance(a, b) -> float:
    ax0, ay0, ax1, ay1 = a
    bx0, by0, bx1, by1 = b
    # Proper crossing: the endpoints of each lie on opposite sides of the other.
    d1 = (bx1 - bx0) * (ay0 - by0) - (by1 - by0) * (ax0 - bx0)
    d2 = (bx1 - bx0) * (ay1 - by0) - (by1 - by0) * (ax1 - bx0)
    d3 = (ax1 - ax0) * (by0 - ay0) - (ay1 - ay0) * (bx0 - ax0)
    d4 = (ax1 - ax0) * (by1 - ay0) - (ay1 - ay0) * (bx1 - ax0)
    if d1 * d2 < 0.0 and d3 * d4 < 0.0:
        return 0.0
    return min(_point_segment_distance(ax0, ay0, *b), _point_segment_distance(ax1, ay1, *b),
               _point_segment_distance(bx0, by0, *a), _point_segment_distance(bx1, by1, *a))


def _paths_come_close(mi: PlanarMotion, mj: PlanarMotion, tau_max: float, reach: float) -> bool:
    """False when the two centre paths never come within ``reach`` (m): no contact possible."""
    if not (_straight(mi) and _straight(mj)):  # a skid's path curves: bound by the travel
        travel = sum(math.hypot(*m.velocity) * tau_max + 0.5 * math.hypot(*m.acceleration) * tau_max * tau_max
                     for m in (mi, mj))
        gap = math.hypot(mi.position[0] - mj.position[0], mi.position[1] - mj.position[1])
        return gap <= reach + travel
    return _segments_distance(_path_segment(mi, tau_max), _path_segment(mj, tau_max)) <= reach


def _approaching(mi: PlanarMotion, mj: PlanarMotion, tau: float, normal, point) -> bool:
    """Closing along the normal somewhere on the contact patch (its centre, where the rollout
    applies the impulse, or an end a spin turns into the partner; translation plus spin), or,
    at zero normal speed, by relative acceleration (pushing)."""
    xi, yi, yawi, vxi, vyi = mi.at(tau)
    xj, yj, yawj, vxj, vyj = mj.at(tau)
    wi = mi.yaw_rate + mi.yaw_accel * tau
    wj = mj.yaw_rate + mj.yaw_accel * tau
    centre, ends = contact_patch(mi.footprint, xi, yi, yawi, mj.footprint, xj, yj, yawj, normal, point)
    normal_speed = min(contact_normal_speed(normal, at, ((xi, yi), (xj, yj)), ((vxi, vyi), (vxj, vyj)), (wi, wj))
                       for at in (centre, *ends))
    if normal_speed < -APPROACH_TOL:
        return True
    normal_accel = ((mi.acceleration[0] - mj.acceleration[0]) * normal[0]
                    + (mi.acceleration[1] - mj.acceleration[1]) * normal[1])
    return closing(normal_speed, normal_accel)


def _swept_square_contact(mi, mj, d0, dv, da, tau_max) -> Contact | None:
    fi, fj = mi.footprint, mj.footprint
    spin = abs(mi.yaw_rate) > 0 or abs(mj.yaw_rate) > 0
    if not spin and dv == (0.0, 0.0) and da == (0.0, 0.0):
        return None  # rigidly moving together (or both at rest): the gap never changes
    # The bounding circles contain the footprints, so they touch no later than the footprints.
    rb = fi.bounding_radius + fj.bounding_radius
    if math.hypot(*d0) > rb:
        tau = _bounding_entry(d0, dv, da, rb, tau_max)
        if tau is None:
            return None
    else:
        tau = 0.0
    # Upper bound of how fast the gap can shrink: speeds and spins only decrease within a
    # sliding segment and are constant in flight; a skidding sphere may speed up (its
    # acceleration is not against its velocity), by at most |a| tau_max.
    closing_bound = (_speed_bound(mi, tau_max) + _speed_bound(mj, tau_max)
                     + abs(mi.yaw_rate) * fi.bounding_radius + abs(mj.yaw_rate) * fj.bounding_radius)
    if closing_bound <= 0:
        return None

    def gap_at(t):
        xi, yi, yawi, _, _ = mi.at(t)
        xj, yj, yawj, _, _ = mj.at(t)
        return footprint_distance(fi, xi, yi, yawi, fj, xj, yj, yawj)

    gap, normal, point = gap_at(tau)
    for _ in range(MAX_CA_ITERATIONS):
        # Touching, or already overlapping (possible only for spinning squares, whose
        # rotation the central impulse cannot stop): a contact as soon as they close in.
        if gap <= CA_TOL and _approaching(mi, mj, tau, normal, point):
            return Contact(tau, normal, point)
        # |gap| / bound never passes a touch: separated, it cannot close faster; overlapping,
        # it cannot open faster (so no contact can start before then). From a touch whose
        # contact points separate, the corners' clearance bound says when one could come back;
        # otherwise at least MIN_CA_STEP, and a step through the surface is bisected (exact roots).
        step = abs(gap) / closing_bound
        if abs(gap) <= CA_TOL:
            step = max(step, clearance_step(mi, mj, tau, tau_max - tau))
        else:
            step = max(step, MIN_CA_STEP)
        nxt = min(tau + step, tau_max)
        if nxt <= tau:
            return None
        new_gap, new_normal, new_point = gap_at(nxt)
        if new_gap < 0.0 <= gap:
            # Stepped through the surface: bisect for the first touch.
            lo, hi, lo_pack = tau, nxt, (gap, normal, point)
            while hi - lo > BISECT_TIME_TOL:
                mid = 0.5 * (lo + hi)
                pack = gap_at(mid)
                if pack[0] < 0.0:
                    hi = mid
                else:
                    lo, lo_pack = mid, pack
            if _approaching(mi, mj, lo, lo_pack[1], lo_pack[2]):
                return Contact(lo, lo_pack[1], lo_pack[2])
            # A touch that separates (a corner turning away): go on from it, not from inside.
            tau, (gap, normal, point) = lo, lo_pack
            continue
        if nxt >= tau_max:
            return None
        tau, gap, normal, point = nxt, new_gap, new_normal, new_point
    # Iteration budget spent (long grazing or spinning overlap): ask to be re-checked from here.
    return Contact(tau, None, point)


def _spin_bound(m: PlanarMotion, tau_end: float) -> float:
    """Upper bound (rad/s) of |yaw rate| within [0, tau_end] (a linear yaw-rate flow)."""
    return max(abs(m.yaw_rate), abs(m.yaw_rate + m.yaw_accel * tau_end))


def _point_clearance_step(point, offset, point_motion: PlanarMotion, square: PlanarMotion, radius: float,
                          tau: float, window: float) -> float:
    """Seconds after tau (at most ``window``) during which a material point of one body (a corner,
    or a circle's centre less its radius) provably stays outside the square ``square``.

    point: (2,) m at tau; offset: (2,) m, the point minus its body's centre; radius: m (0 for a
    corner). The square's signed distance is convex and 1-Lipschitz in the point's position q in
    the square's frame, so ``d(tau + s) >= d + d' s - Q s^2 / 2`` with d' the point's normal speed
    relative to the square's material there and Q a bound of |q''| over the window
    (q'' = r'' - 2 w_S J r' - alpha_S J r - w_S^2 r, r = point - square centre).
    Returns the first positive root of that bound (0 when the point is inside, or touching and closing).
    """
    sx, sy, syaw, svx, svy = square.at(tau)
    px, py, _, pvx, pvy = point_motion.at(tau)
    w_point = point_motion.yaw_rate + point_motion.yaw_accel * tau
    w_square = square.yaw_rate + square.yaw_accel * tau
    distance, gx, gy = point_square_distance(point[0], point[1], sx, sy, syaw, square.footprint.size)
    clearance = distance - radius
    if clearance < 0.0:
        return 0.0
    rx, ry = point[0] - sx, point[1] - sy
    # Velocity of the point minus that of the square's material at the point.
    ux = pvx - w_point * offset[1] - (svx - w_square * ry)
    uy = pvy + w_point * offset[0] - (svy + w_square * rx)
    rate = gx * ux + gy * uy
    end = tau + window
    lever = math.hypot(*offset)
    spin_p, spin_s = _spin_bound(point_motion, end), _spin_bound(square, end)
    relative_speed = _speed_bound(point_motion, end) + spin_p * lever + _speed_bound(square, end)
    relative_accel = (math.hypot(*point_motion.acceleration) + (abs(point_motion.yaw_accel) + spin_p * spin_p) * lever
                      + math.hypot(*square.acceleration))
    reach = math.hypot(rx, ry) + relative_speed * window
    curvature = relative_accel + 2.0 * spin_s * relative_speed + (abs(square.yaw_accel) + spin_s * spin_s) * reach
    if curvature <= 0.0:
        return window if rate >= 0.0 else min(window, clearance / -rate)
    return min(window, (rate + math.sqrt(rate * rate + 2.0 * curvature * clearance)) / curvature)


def clearance_step(mi: PlanarMotion, mj: PlanarMotion, tau: float, window: float) -> float:
    """Seconds after tau during which two footprints, one at least a square, provably do not start
    touching, at least MIN_CLEARANCE_STEP and at most ``window`` (and CLEARANCE_WINDOW).

    Two convex polygons (or a circle and a square) first touch where a corner of one (the circle's
    centre, less its radius) reaches the other; each such point keeps a quadratic lower bound of
    its clearance (``_point_clearance_step``), so a touch whose contact points separate (a spinning
    corner turning away) is searched again exactly when a corner could come back, not a fixed step
    later. Circle pairs: ``window`` (their contact times are exact roots).
    """
    window = min(window, CLEARANCE_WINDOW)
    if window <= 0.0:
        return MIN_CLEARANCE_STEP
    step = window
    for point_motion, square in ((mi, mj), (mj, mi)):
        if square.footprint.kind != SQUARE:
            continue
        x, y, yaw, _, _ = point_motion.at(tau)
        if point_motion.footprint.kind == CIRCLE:
            points = [((x, y), (0.0, 0.0), point_motion.footprint.size)]
        else:
            points = [(corner, (corner[0] - x, corner[1] - y), 0.0)
                      for corner in _square_corners(x, y, yaw, point_motion.footprint.size)]
        for point, offset, radius in points:
            step = min(step, _point_clearance_step(point, offset, point_motion, square, radius, tau, window))
    return max(step, MIN_CLEARANCE_STEP)


def _bounding_entry(d0, dv, da, radius_sum, tau_max):
    """First time (s) the bounding circles touch, approaching or not (None if never in the window)."""
    speed_bound = math.hypot(*dv) * tau_max + 0.5 * math.hypot(*da) * tau_max * tau_max
    if math.hypot(*d0) - radius_sum > speed_bound:
        return None
    inside = real_roots(_quartic_gap_coefficients(d0, dv, da, radius_sum), 0.0, tau_max)
    return max(float(inside[0]) - 1e-9, 0.0) if inside else None


# --------------------------------------------------------------------------- friction at impacts

def pair_friction(mu_i: float | None, mu_j: float | None) -> float:
    """Coulomb coefficient between two bodies: the mean of their ``contact_friction`` (None counts as 0)."""
    return 0.5 * ((mu_i or 0.0) + (mu_j or 0.0))


@dataclass(frozen=True)
class TangentialImpulse:
    """A friction impulse at an impact, in the contact's tangent plane.

    impulse: N s on body i along the horizontal tangent ``t = (-n_y, n_x)``
    (body j receives the opposite); vertical: N s on body i along +z at the
    contact point (only rolling spheres' contact points slip vertically; the
    floor takes the linear part, the moment changes their rolling spin);
    yaw_rate_change_i, yaw_rate_change_j: rad/s from the horizontal impulse's
    moment about each centre; sticking: whether the slip's share
    ``slip_removal`` was removed (True) or the Coulomb limit acted (False).
    """

    impulse: float
    vertical: float
    yaw_rate_change_i: float
    yaw_rate_change_j: float
    sticking: bool


def tangential_impulse(
    normal: tuple[float, float],
    relative_velocity: tuple[float, float],
    yaw_rates: tuple[float, float],
    levers: tuple[float, float],
    masses: tuple[float, float],
    yaw_inertias: tuple[float, float],
    normal_impulse: float,
    friction: float,
    slip_removal: float = 1.0,
    vertical_slip: float = 0.0,
    vertical_compliance: float = 0.0,
) -> TangentialImpulse:
    """Coulomb friction impulse of an impact between bodies i and j, in closed form.

    normal: (2,) unit, from j to i. relative_velocity: (2,) m/s, ``v_i - v_j``
    of the centres just before. yaw_rates: (w_i, w_j) rad/s. levers: (l_i, l_j)
    m, ``(contact point - centre) . n`` of each body (the arm of a tangential
    force about the vertical axis: ``(r x t)_z = r . n``). masses: kg;
    yaw_inertias: kg m^2 about the vertical axis. normal_impulse: N s (>= 0)
    on i along n. friction: the pair's Coulomb coefficient.
    vertical_slip: m/s, vertical velocity of i's contact point minus j's
    (a rolling sphere's spin moves its equator up or down);
    vertical_compliance: 1/kg, the change of that slip per N s of vertical
    impulse on i (``sum r^2 / I`` over the rolling spheres of the pair; 0: none).

    Horizontally the contact points slip at ``u = (v_i - v_j).t + w_i l_i - w_j l_j``;
    an impulse ``J`` along t on i (and -J on j) changes u by ``J k`` with
    ``k = 1/m_i + 1/m_j + l_i^2 / I_i + l_j^2 / I_j``. The impulse that stops
    the slip is ``-u / k`` (sticking), likewise ``-vertical_slip / vertical_compliance``
    vertically; an impact removes the share ``slip_removal`` of the slip (1: a
    rigid contact sticks; a soft contact that lasts a short time removes
    less, World.contact_slip_removal), and Coulomb bounds the impulse's
    magnitude in the tangent plane by ``friction * normal_impulse`` (the
    impulse keeps its direction): friction can stop the slip but never reverse it.
    """
    nx, ny = normal
    tx, ty = -ny, nx
    li, lj = levers
    slip = relative_velocity[0] * tx + relative_velocity[1] * ty + yaw_rates[0] * li - yaw_rates[1] * lj
    k = 1.0 / masses[0] + 1.0 / masses[1] + li * li / yaw_inertias[0] + lj * lj / yaw_inertias[1]
    horizontal = -slip_removal * slip / k
    vertical = -slip_removal * vertical_slip / vertical_compliance if vertical_compliance > 0.0 else 0.0
    limit = friction * max(normal_impulse, 0.0)
    size = math.hypot(horizontal, vertical)
    sticking = size <= limit
    if not sticking:
        horizontal, vertical = horizontal * limit / size, vertical * limit / size
    return TangentialImpulse(horizontal, vertical, li * horizontal / yaw_inertias[0], -lj * horizontal / yaw_inertias[1], sticking)


@dataclass(frozen=True)
class CollisionImpulse:
    """The response to one impact between bodies i and j (planar rigid bodies).

    normal_impulse: N s on i along n (j receives the opposite), at the contact point.
    velocity_change_i, velocity_change_j: (2,) m/s of the centres.
    yaw_rate_change_i, yaw_rate_change_j: rad/s, from the moments of the normal
    and the friction impulse about each centre.
    friction: the tangential part (None without friction between the bodies).
    """

    normal_impulse: float
    velocity_change_i: tuple[float, float]
    velocity_change_j: tuple[float, float]
    yaw_rate_change_i: float
    yaw_rate_change_j: float
    friction: TangentialImpulse | None


def contact_normal_speed(
    normal: tuple[float, float], point: tuple[float, float],
    centres: tuple[tuple[float, float], tuple[float, float]],
    velocities: tuple[tuple[float, float], tuple[float, float]],
    yaw_rates: tuple[float, float],
) -> float:
    """Relative normal speed (m/s, < 0 approaching) of the two bodies' material points at ``point``.

    normal: (2,) unit from j to i; centres (m), velocities (m/s): (2,) each, of i then j;
    yaw_rates: rad/s. A point's velocity is ``v + w e_z x r`` (r from the centre), and
    ``(e_z x r) . n = r x n``.
    """
    nx, ny = normal
    speed = 0.0
    for sign, (cx, cy), (vx, vy), w in zip((1.0, -1.0), centres, velocities, yaw_rates):
        arm = (point[0] - cx) * ny - (point[1] - cy) * nx
        speed += sign * (vx * nx + vy * ny + w * arm)
    return speed


def collision_impulse(
    normal: tuple[float, float],
    point: tuple[float, float],
    centres: tuple[tuple[float, float], tuple[float, float]],
    velocities: tuple[tuple[float, float], tuple[float, float]],
    yaw_rates: tuple[float, float],
    masses: tuple[float, float],
    yaw_inertias: tuple[float, float],
    restitution: float,
    friction: float = 0.0,
    slip_removal: float = 1.0,
    vertical_slip: float = 0.0,
    vertical_compliance: float = 0.0,
    patch_ends: tuple[tuple[float, float], ...] = (),
) -> CollisionImpulse:
    """Impulse of a planar rigid-body impact at the contact point, in closed form (the one owner).

    normal: (2,) unit from j to i; point: (2,) m, where the impulse acts (the
    contact patch's centre); centres, velocities: (2,) m and m/s of i then j;
    yaw_rates: rad/s; masses: kg; yaw_inertias: kg m^2 about z; restitution e;
    friction: the pair's Coulomb coefficient (0: frictionless); slip_removal,
    vertical_slip, vertical_compliance: as in ``tangential_impulse``.

    1. Normal: ``j = -(1 + e) u_n / (1/m_i + 1/m_j + (r_i x n)^2/I_i + (r_j x n)^2/I_j)``
       with ``u_n`` the contact points' relative normal speed
       (``contact_normal_speed``), applied at the point: it changes the yaw
       rates by ``(r x n) j / I`` (zero for a circle: its r is along n).
    2. Friction: ``tangential_impulse`` on the velocities after step 1
       (Coulomb-bounded by ``friction * j``).
    3. Friction at an off-centre point can turn the contact points towards each
       other again; a last normal impulse then only stops that approach (u_n -> 0).
    4. ``patch_ends`` ((2,) m each, the ends of a face pressed flat): a spin can still
       turn one end into the partner; a normal impulse at that end only stops its
       approach (a few passes over the centre and the ends, as sequential impulses).
    Each step removes kinetic energy or keeps it (e <= 1); every impulse acts
    at the same point on both bodies, equal and opposite, so linear momentum
    and angular momentum about any point are conserved.
    """
    nx, ny = normal
    (mi, mj) = masses
    inertia_i, inertia_j = (max(inertia, MIN_YAW_INERTIA) for inertia in yaw_inertias)
    arm_i = (point[0] - centres[0][0]) * ny - (point[1] - centres[0][1]) * nx  # r_i x n
    arm_j = (point[0] - centres[1][0]) * ny - (point[1] - centres[1][1]) * nx
    lever_i = (point[0] - centres[0][0]) * nx + (point[1] - centres[0][1]) * ny  # r_i x t = r_i . n
    lever_j = (point[0] - centres[1][0]) * nx + (point[1] - centres[1][1]) * ny
    k_normal = 1.0 / mi + 1.0 / mj + arm_i * arm_i / inertia_i + arm_j * arm_j / inertia_j
    (vix, viy), (vjx, vjy) = velocities
    wi, wj = yaw_rates

    def push(size, dx, dy, moment_i, moment_j):
        """Apply ``size`` N s along (dx, dy) on i (opposite on j) with the given moment arms."""
        nonlocal vix, viy, vjx, vjy, wi, wj
        vix, viy = vix + size * dx / mi, viy + size * dy / mi
        vjx, vjy = vjx - size * dx / mj, vjy - size * dy / mj
        wi, wj = wi + moment_i * size / inertia_i, wj - moment_j * size / inertia_j

    def normal_speed():
        return (vix - vjx) * nx + (viy - vjy) * ny + wi * arm_i - wj * arm_j

    approach = normal_speed()
    j_normal = -(1.0 + restitution) * approach / k_normal if approach < 0.0 else 0.0
    push(j_normal, nx, ny, arm_i, arm_j)
    tangential = None
    if friction > 0.0:
        tangential = tangential_impulse(
            normal, (vix - vjx, viy - vjy), (wi, wj), (lever_i, lever_j), masses, yaw_inertias,
            j_normal, friction, slip_removal, vertical_slip, vertical_compliance)
        push(tangential.impulse, -ny, nx, lever_i, lever_j)
        again = normal_speed()
        if again < 0.0:
            extra = -again / k_normal
            push(extra, nx, ny, arm_i, arm_j)
            j_normal += extra
    arms = [(arm_i, arm_j)] + [((end[0] - centres[0][0]) * ny - (end[1] - centres[0][1]) * nx,
                                (end[0] - centres[1][0]) * ny - (end[1] - centres[1][1]) * nx) for end in patch_ends]
    for _ in range(PATCH_END_PASSES if patch_ends else 0):
        for end_arm_i, end_arm_j in arms:
            approach = (vix - vjx) * nx + (viy - vjy) * ny + wi * end_arm_i - wj * end_arm_j
            if approach < 0.0:
                extra = -approach / (1.0 / mi + 1.0 / mj + end_arm_i * end_arm_i / inertia_i + end_arm_j * end_arm_j / inertia_j)
                push(extra, nx, ny, end_arm_i, end_arm_j)
                j_normal += extra
    (v0ix, v0iy), (v0jx, v0jy) = velocities
    return CollisionImpulse(j_normal, (vix - v0ix, viy - v0iy), (vjx - v0jx, vjy - v0jy),
                            wi - yaw_rates[0], wj - yaw_rates[1], tangential)
