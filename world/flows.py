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
* ``SKID`` a sphere whose contact point slips (``start_sphere_segment``):
  kinetic friction ``mu g`` against the slip velocity ``u = v - v_spin``
  (``v_spin = (omega x r e_z)_xy``, the velocity of rolling at the current
  spin). For a solid sphere (I = 2/5 m r^2) the slip decays at
  ``(1 + 5/2) mu g`` along a constant direction, so the skid is one
  quadratic with a constant acceleration vector and ends exactly at
  ``|u| / (3.5 mu g)``; from then on the sphere rolls. Started without spin
  it rolls on at 5/7 of its speed.
* Rolling is a ``SLIDE`` segment at the rolling deceleration
  ``mu_roll g`` (``Body.rolling_friction``; a rolling sphere's contact point
  does not slip, its spin follows its velocity).

Yaw (rotation about +z), slide and spin coupled (``spin_slide_stop_time``):
a flat body that slides at speed ``v`` and spins at ``w`` on the plane
(Coulomb friction, uniform pressure) loses speed and spin together and
stops both at the same time (Farkas, Bartels, Unger & Wolf, "Frictional
coupling between sliding and spinning motion", Phys. Rev. Lett. 90, 248302,
2003); while it spins, the friction force against the slide is smaller than
``mu m g``. Closed-form approximation: speed and spin both decay linearly
to one common stop ``T``, chosen so that the energy the friction removes at
the start matches its power ``mu m g <|slip|>``, with the mean slip speed of
the face approximated by ``sqrt(v^2 + (w rho)^2)`` (``rho``: the face's mean
distance from the centre, ``Shape.footprint_mean_radius``), exact for a pure
slide (``T = v / (mu g)``) and a pure spin (``T = (I/m) w / (mu g rho)``).
A body spinning in place is a ``SLIDE`` segment of zero speed that ends at
its spin's stop. At rest the yaw rate is zero; in flight it is constant.
Collisions are not this module's business: the rollout (world/rollout.py)
sets both bodies' yaw rate at a collision (``contacts.collision_impulse``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

SLIDE, REST, FLIGHT, SKID = "slide", "rest", "flight", "skid"

# Speeds below this are treated as zero (m/s): avoids stop events micro-seconds
# after a collision that left a body with a rounding-level velocity.
REST_SPEED = 1e-9
# Yaw rates below this (rad/s) are treated as zero when a body spins in place.
REST_SPIN = 1e-9
# A body whose centre is this far (m) above its rest height is in flight.
FLIGHT_HEIGHT_TOL = 1e-9
# A sphere whose contact point slips slower than this (m/s) rolls.
SLIP_TOL = 1e-9
# Solid sphere, I = 2/5 m r^2: friction F slows the centre by F/m and spins the
# contact point up by F r^2 / I = 5/2 F/m, so the slip decays 1 + 5/2 times faster.
SOLID_SPHERE_SLIP_FACTOR = 1.0 + 5.0 / 2.0


@dataclass(frozen=True)
class Segment:
    """One closed-form piece of a body's motion, valid from ``t0`` until the next segment.

    position, velocity, acceleration: (3,) world frame, m, m/s, m/s^2 at t0.
    yaw (rad), yaw_rate (rad/s), yaw_accel (rad/s^2) at t0.
    end: time (s) of the segment's own mode change (stop, landing, end of a skid), inf if none.
    active: False for the pieces before a body enters or after it is removed.
    slip: (2,) m/s, a sphere's slip velocity ``v - v_spin`` at t0 (SKID and
    FLIGHT of a rolling sphere; zero otherwise: the spin follows the motion).
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
    slip: tuple[float, float] = (0.0, 0.0)

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


    def spin_velocity_at(self, t: float) -> tuple[float, float]:
        """(2,) m/s: the planar velocity of rolling at the spin the body has at ``t``.

        A skid's slip decays linearly to zero at ``end``; in flight the spin is
        constant; otherwise the spin follows the velocity (rolling, rest).
        """
        _, v, _, _ = self.state_at(t)
        if self.mode == SKID:
            share = (self.end - t) / (self.end - self.t0)
            return v[0] - self.slip[0] * share, v[1] - self.slip[1] * share
        return v[0] - self.slip[0], v[1] - self.slip[1]


def stopping_time(speed: float, friction: float, gravity: float) -> float:
    """Exact Coulomb stopping time (s) of a body sliding at ``speed`` (m/s)."""
    return speed / (friction * gravity)


def stopping_distance(speed: float, friction: float, gravity: float) -> float:
    """Distance (m) slid before stopping: ``|v|^2 / (2 mu g)``."""
    return speed * speed / (2.0 * friction * gravity)


def spin_slide_stop_time(speed: float, yaw_rate: float, friction: float, gravity: float,
                         spin_arm: float, yaw_inertia_per_mass: float) -> float:
    """Common stop time (s) of a body sliding at ``speed`` (m/s) and spinning at ``yaw_rate`` (rad/s).

    spin_arm: m, the face's mean distance from the centre (``Shape.footprint_mean_radius``);
    yaw_inertia_per_mass: m^2. ``T = (v^2 + (I/m) w^2) / (mu g sqrt(v^2 + (w rho)^2))``: the
    kinetic energy over the friction's power at the start, times 2 (linear decay of both);
    ``v / (mu g)`` without spin (module doc).
    """
    spin_speed = yaw_rate * spin_arm
    slip = math.hypot(speed, spin_speed)
    if slip == 0.0:
        return 0.0
    return (speed * speed + yaw_inertia_per_mass * yaw_rate * yaw_rate) / (friction * gravity * slip)


def start_segment(
    t0: float,
    position: tuple[float, float, float],
    velocity: tuple[float, float, float],
    yaw: float,
    yaw_rate: float,
    rest_height: float,
    friction: float,
    gravity: float,
    spin_arm: float = 0.0,
    yaw_inertia_per_mass: float = 0.0,
) -> Segment:
    """The closed-form segment a body follows from state (position, velocity, yaw) at ``t0``.

    Chooses flight when the body is above its rest height or moves upwards,
    otherwise sliding (or rest when its horizontal speed is zero). spin_arm (m)
    and yaw_inertia_per_mass (m^2): the body's ``Shape.footprint_mean_radius``
    and ``Shape.yaw_inertia_per_mass``; with a spin_arm, slide and spin are
    coupled (``spin_slide_stop_time``) and a body can spin in place; without,
    the spin decays linearly to the translational stop.
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
    coupled = spin_arm > 0.0 and abs(yaw_rate) > REST_SPIN and friction > 0.0
    if speed <= REST_SPEED:
        if not coupled:
            return Segment(t0, (px, py, rest_height), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0),
                           yaw, 0.0, 0.0, REST, math.inf)
        # Spinning in place: the spin decays at the floor's friction torque to its stop.
        t_stop = spin_slide_stop_time(0.0, yaw_rate, friction, gravity, spin_arm, yaw_inertia_per_mass)
        if not t_stop > 0.0:  # no inertia to carry a spin
            return Segment(t0, (px, py, rest_height), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0),
                           yaw, 0.0, 0.0, REST, math.inf)
        return Segment(t0, (px, py, rest_height), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0),
                       yaw, yaw_rate, -yaw_rate / t_stop, SLIDE, t0 + t_stop)
    if coupled:
        t_stop = spin_slide_stop_time(speed, yaw_rate, friction, gravity, spin_arm, yaw_inertia_per_mass)
        decel = speed / t_stop
    else:
        decel = friction * gravity
        t_stop = speed / decel
    ax, ay = -decel * vx / speed, -decel * vy / speed
    # Yaw rate decays linearly to zero exactly at the stop (common to slide and spin).
    yaw_accel = -yaw_rate / t_stop
    return Segment(t0, (px, py, rest_height), (vx, vy, 0.0), (ax, ay, 0.0),
                   yaw, yaw_rate, yaw_accel, SLIDE, t0 + t_stop)


def start_sphere_segment(
    t0: float,
    position: tuple[float, float, float],
    velocity: tuple[float, float, float],
    spin_velocity: tuple[float, float],
    yaw: float,
    rest_height: float,
    skid_friction: float,
    rolling_friction: float,
    gravity: float,
) -> Segment:
    """The segment of a rolling-model sphere from (position, velocity, spin) at ``t0``.

    spin_velocity: (2,) m/s, ``(omega x r e_z)_xy``. Flight as in
    ``start_segment`` (the spin is carried); a slipping sphere skids
    (kinetic ``skid_friction``); one that does not slip rolls (a slide at
    ``rolling_friction``, dimensionless: deceleration ``rolling_friction * g``).
    """
    ux, uy = velocity[0] - spin_velocity[0], velocity[1] - spin_velocity[1]
    slip = math.hypot(ux, uy)
    height = position[2] - rest_height
    if height > FLIGHT_HEIGHT_TOL or velocity[2] > REST_SPEED:
        flight = start_segment(t0, position, velocity, yaw, 0.0, rest_height, skid_friction, gravity)
        return replace(flight, slip=(ux, uy))
    if slip <= SLIP_TOL:
        return start_segment(t0, position, velocity, yaw, 0.0, rest_height, rolling_friction, gravity)
    decel = skid_friction * gravity
    t_skid = slip / (SOLID_SPHERE_SLIP_FACTOR * decel)
    return Segment(t0, (position[0], position[1], rest_height), (velocity[0], velocity[1], 0.0),
                   (-decel * ux / slip, -decel * uy / slip, 0.0), yaw, 0.0, 0.0, SKID, t0 + t_skid,
                   slip=(ux, uy))


def inactive_segment(t0: float, position, yaw: float) -> Segment:
    """A placeholder piece for times when the body is not in the world."""
    return Segment(t0, tuple(float(v) for v in position), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0),
                   float(yaw), 0.0, 0.0, REST, math.inf, active=False)


def evaluate_yaw_rates(segments: list[Segment], times: np.ndarray) -> np.ndarray:
    """(T,) rad/s: a body's yaw rate at ``times`` (s) from its pieces sorted by ``t0``
    (0 before the first piece)."""
    starts = np.array([s.t0 for s in segments])
    index = np.searchsorted(starts, times, side="right") - 1
    before = index < 0
    index = np.clip(index, 0, len(segments) - 1)
    rates = np.array([(s.yaw_rate, s.yaw_accel) for s in segments])[index]
    tau = np.where(before, 0.0, times - starts[index])
    return np.where(before, 0.0, rates[:, 0] + rates[:, 1] * tau)


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
