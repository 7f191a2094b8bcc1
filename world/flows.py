"""Closed-form motion between events (the flows Phi_k of the paper, Appendix A.2).

Every segment produced here is an exact quadratic in time: the rollout ends a
sliding segment at its exact Coulomb stopping time (a ``stop`` event) and a
flight segment at its exact landing time, so no flow ever needs a clamp and
pairwise separations stay polynomial.

Modes (see ``Segment.mode``):

* ``SLIDE`` supported sliding on the plane z = 0 with Coulomb friction:
  constant deceleration ``mu * g`` against the velocity, which never reverses;
  the speed reaches zero exactly at ``|v| / (mu g)``.
* ``REST`` at rest on the plane (a sliding segment of zero speed).
* ``FLIGHT`` ballistic in 3D: ``p(t) = p_k + v_k t - g t^2 e_z / 2``,
  no friction, until the body's rest height is reached again.

Yaw (rotation about +z): while a body slides its yaw rate decays linearly and
reaches zero exactly at the translational stopping time (constant angular
deceleration, like the linear one); at rest the yaw rate is zero; in flight
the yaw rate is constant. Collisions are not this module's business: the
rollout (world/rollout.py) sets both bodies' yaw rate to zero at a collision,
since the model has no moments of inertia to carry spin through an impulse.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

SLIDE, REST, FLIGHT = "slide", "rest", "flight"

# Speeds below this are treated as zero (m/s): avoids stop events micro-seconds
# after a collision that left a body with a rounding-level velocity.
REST_SPEED = 1e-9
# A body whose centre is this far (m) above its rest height is in flight.
FLIGHT_HEIGHT_TOL = 1e-9


@dataclass(frozen=True)
class Segment:
    """One closed-form piece of a body's motion, valid from ``t0`` until the next segment.

    position, velocity, acceleration: (3,) world frame, m, m/s, m/s^2 at t0.
    yaw (rad), yaw_rate (rad/s), yaw_accel (rad/s^2) at t0.
    end: time (s) of the segment's own mode change (stop or landing), inf if none.
    active: False for the pieces before a body enters or after it is removed.
    """

    t0: float
    position: tuple[float, float, float]
    velocity: tuple[float, float, float]
    acceleration: tuple[float, float, float]
    yaw: float
    yaw_rate: float
    yaw_accel: float
    mode: str
    end: float
    active: bool = True

    def state_at(self, t: float) -> tuple[tuple[float, float, float], tuple[float, float, float], float, float]:
        """Position (3,), velocity (3,), yaw, yaw rate at absolute time ``t`` (s)."""
        tau = t - self.t0
        p, v, a = self.position, self.velocity, self.acceleration
        pos = (p[0] + v[0] * tau + 0.5 * a[0] * tau * tau,
               p[1] + v[1] * tau + 0.5 * a[1] * tau * tau,
               p[2] + v[2] * tau + 0.5 * a[2] * tau * tau)
        vel = (v[0] + a[0] * tau, v[1] + a[1] * tau, v[2] + a[2] * tau)
        yaw = self.yaw + self.yaw_rate * tau + 0.5 * self.yaw_accel * tau * tau
        return pos, vel, yaw, self.yaw_rate + self.yaw_accel * tau


def stopping_time(speed: float, friction: float, gravity: float) -> float:
    """Exact Coulomb stopping time (s) of a body sliding at ``speed`` (m/s)."""
    return speed / (friction * gravity)


def stopping_distance(speed: float, friction: float, gravity: float) -> float:
    """Distance (m) slid before stopping: ``|v|^2 / (2 mu g)``."""
    return speed * speed / (2.0 * friction * gravity)


def start_segment(
    t0: float,
    position: tuple[float, float, float],
    velocity: tuple[float, float, float],
    yaw: float,
    yaw_rate: float,
    rest_height: float,
    friction: float,
    gravity: float,
) -> Segment:
    """The closed-form segment a body follows from state (position, velocity, yaw) at ``t0``.

    Chooses flight when the body is above its rest height or moves upwards,
    otherwise sliding (or rest when its horizontal speed is zero).
    """
    px, py, pz = position
    vx, vy, vz = velocity
    height = pz - rest_height
    if height > FLIGHT_HEIGHT_TOL or vz > REST_SPEED:
        # Ballistic: land when z(tau) = rest_height on the descending branch.
        disc = vz * vz + 2.0 * gravity * max(height, 0.0)
        t_land = (vz + math.sqrt(disc)) / gravity
        return Segment(t0, (px, py, pz), (vx, vy, vz), (0.0, 0.0, -gravity),
                       yaw, yaw_rate, 0.0, FLIGHT, t0 + t_land)
    speed = math.hypot(vx, vy)
    if speed <= REST_SPEED:
        return Segment(t0, (px, py, rest_height), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0),
                       yaw, 0.0, 0.0, REST, math.inf)
    decel = friction * gravity
    t_stop = speed / decel
    ax, ay = -decel * vx / speed, -decel * vy / speed
    # Yaw rate decays linearly to zero exactly at the translational stop.
    yaw_accel = -yaw_rate / t_stop
    return Segment(t0, (px, py, rest_height), (vx, vy, 0.0), (ax, ay, 0.0),
                   yaw, yaw_rate, yaw_accel, SLIDE, t0 + t_stop)


def inactive_segment(t0: float, position, yaw: float) -> Segment:
    """A placeholder piece for times when the body is not in the world."""
    return Segment(t0, tuple(float(v) for v in position), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0),
                   float(yaw), 0.0, 0.0, REST, math.inf, active=False)


def evaluate_segments(segments: list[Segment], times: np.ndarray) -> tuple[np.ndarray, ...]:
    """Sample a body's piecewise flow at many times at once (vectorised).

    segments: the body's pieces sorted by ``t0``; times: (T,) seconds.
    Returns positions (T, 3), velocities (T, 3), yaw (T,), active (T,) bool.
    Times before the first piece take the first piece's state, inactive.
    """
    starts = np.array([s.t0 for s in segments])
    index = np.searchsorted(starts, times, side="right") - 1
    before = index < 0
    index = np.clip(index, 0, len(segments) - 1)
    p0 = np.array([s.position for s in segments])[index]
    v0 = np.array([s.velocity for s in segments])[index]
    a0 = np.array([s.acceleration for s in segments])[index]
    yaw_params = np.array([(s.yaw, s.yaw_rate, s.yaw_accel) for s in segments])[index]
    active = np.array([s.active for s in segments])[index] & ~before
    tau = np.where(before, 0.0, times - starts[index])[:, None]
    positions = p0 + v0 * tau + 0.5 * a0 * tau * tau
    velocities = v0 + a0 * tau
    t1 = tau[:, 0]
    yaw = yaw_params[:, 0] + yaw_params[:, 1] * t1 + 0.5 * yaw_params[:, 2] * t1 * t1
    return positions, velocities, yaw, active
