"""Event-driven execution of a world: closed-form segments, exact events, impulses.

``simulate`` advances from event to event (entry, removal, Coulomb stop,
landing, pairwise contact), applies each, and keeps every body's piecewise
closed-form flow. Per-frame records are sampled only at the end, vectorised,
so the frame rate never changes the trajectory.

A rollout starts from the bodies' initial states (``Body.initial``: position,
velocity, yaw, yaw rate at ``initial.time``); bodies with a later
``initial.time`` enter the world then. Time 0 is frame 0.

Collision response (paper eq. 3): ``j = -(1 + e) (v_i - v_j).n / (1/m_i + 1/m_j)``
along the footprint contact normal ``n`` (from j to i), applied to the linear
velocities (central: no torque). The pair's restitution is
``World.pair_restitution`` if given, else ``min(e_i, e_j)``. Bodies with
``contact_friction`` also get the friction impulse of
``world.contacts.tangential_impulse`` (Coulomb, sticking limit, the world's
slip share): it changes the linear velocities, gives cubes and cylinders
their spin about z, and brakes a rolling sphere's spin. Without friction a
collision stops the yaw rate of both bodies (no angular impulse; otherwise a
spinning cube would keep sweeping its corners into its partner). A spinning
cube whose corner reaches a body while the centres separate makes a
collision with zero impulse that only stops the spin.

Rolling spheres (``Body.rolling_friction`` set): a collision changes the
velocity but not the spin, so the sphere skids until its contact point stops
slipping (flows.SKID, an internal event like landing), then rolls.

Zeno guard: a pair that collides again with a normal approach speed below
``SETTLE_SPEED``, or for the ``ZENO_REPEATS + 1``-th time within ``ZENO_INTERVAL``, is in
sustained (pushing) contact, which a chain of impulses would resolve only in
infinitely many events. It is settled instead: the pair, together with every
body touching it that it collided with within ``ZENO_INTERVAL`` (a jammed
cluster, e.g. a body squeezed between two others), takes the cluster's common
momentum velocity (perfectly inelastic, energy never increases) and the
mass-weighted friction ``sum(m_k mu_k) / sum(m_k)``, so they slide together
and stop together. ``MAX_EVENTS`` caps the loop in any case; hitting
it is recorded in ``Rollout.notes``.
"""

from __future__ import annotations

import math
from typing import Callable, Sequence

import numpy as np

from world.timebase import CONTACT_EPISODE_GAP_SECONDS, frame_of
from world.camera import centre_in_view, view_events
from world.contacts import (CIRCLE, SQUARE, Contact, Footprint, PlanarMotion, clearance_step, closing, collision_impulse, contact_normal_speed,
                            contact_patch, footprint_distance, pair_friction, predict_contact)
from world.edits import apply_edits
from world.flows import (FLIGHT, REST, SKID, Segment, evaluate_segments, evaluate_yaw_rates, inactive_segment,
                         start_segment, start_sphere_segment)
from world.types import Body, Edit, Event, Rollout, World

MAX_EVENTS = 20_000
SETTLE_SPEED = 1e-3  # m/s
ZENO_INTERVAL = 1e-3  # s
ZENO_REPEATS = 3  # collisions of one pair within ZENO_INTERVAL before it is settled
INITIAL_OVERLAP_TOL = 1e-6  # m: bodies entering together may overlap at most this much
HORIZON_FACTOR = 1.2
# Collisions of one pair closer than this (s) are one contact episode, as the
# scene generator's ground truth counts them (synth: 0.2 s debounce).
CONTACT_EPISODE_GAP = CONTACT_EPISODE_GAP_SECONDS
CLUSTER_GAP = 1e-6  # m: bodies this close belong to the same jammed cluster when settling
# A pair whose footprints stay within this gap is still touching (one contact
# episode while a body slides along another); MuJoCo's soft contacts in the
# ground truth likewise keep a sliding pair in contact.
EPISODE_TOUCH_GAP = 2e-3  # m
EPISODE_PROBE_STEP = 5e-3  # s: sampling step of the gap between two collisions of a pair


def default_horizon(world: World) -> int:
    """Observed frames plus 20 % (at least one frame)."""
    return max(1, math.ceil(world.observed_frames * HORIZON_FACTOR - 1e-9))


def footprint_of(body: Body) -> Footprint:
    return Footprint(SQUARE, body.shape.half_extent) if body.shape.kind == "cube" else Footprint(CIRCLE, body.shape.radius)


def pair_restitution(world: World) -> dict[tuple[int, int], float]:
    """Pair table {(id_a, id_b) sorted: e} from the world's overrides."""
    return {(min(a, b), max(a, b)): float(e) for a, b, e in world.pair_restitution}


def _validate_initial_overlaps(world: World) -> None:
    bodies = world.bodies
    for a in range(len(bodies)):
        for b in range(a + 1, len(bodies)):
            ba, bb = bodies[a], bodies[b]
            if ba.initial.time != bb.initial.time:
                continue
            gap, _, _ = footprint_distance(
                footprint_of(ba), ba.initial.position[0], ba.initial.position[1], ba.initial.yaw,
                footprint_of(bb), bb.initial.position[0], bb.initial.position[1], bb.initial.yaw)
            if gap < -INITIAL_OVERLAP_TOL:
                raise ValueError(
                    f"bodies[{b}].initial.position: body {bb.id} overlaps body {ba.id} by {-gap:.3g} m "
                    f"at t={ba.initial.time:g} s (tolerance {INITIAL_OVERLAP_TOL:g} m)")


class _Engine:
    """Mutable event-loop state; private to ``simulate`` (the public API stays pure)."""

    def __init__(self, world: World, t_end: float, use_anchor: bool = False) -> None:
        self.world = world
        self.t_end = t_end
        self.anchor = world.anchor if use_anchor else None
        self.g = world.gravity
        self.bodies = world.bodies
        n = len(self.bodies)
        self.footprints = [footprint_of(b) for b in self.bodies]
        self.pair_e = pair_restitution(world)
        self.segments: list[Segment | None] = [None] * n
        self.logs: list[list[Segment]] = [[] for _ in range(n)]
        self.status = ["pending"] * n
        self.friction = [b.friction for b in self.bodies]
        self.pred: dict[tuple[int, int], tuple[float, object]] = {}
        self.last_collision: dict[tuple[int, int], list[float]] = {}
        self.events: list[tuple[float, int, Event]] = []
        self.notes: list[str] = []
        self.event_count = 0
        self.contacts_enabled = True

    # ------------------------------------------------------------------ body events
    def _body_next(self, k: int) -> float:
        body = self.bodies[k]
        if self.status[k] == "pending":
            return body.initial.time
        if self.status[k] == "gone":
            return math.inf
        until = body.active_until if body.active_until is not None else math.inf
        return min(self.segments[k].end, until)

    def _set_segment(self, k: int, t: float, position, velocity, yaw: float, yaw_rate: float,
                     spin_velocity: tuple[float, float] | None = None, plain: bool = False) -> None:
        """Start body k's next segment. spin_velocity: (2,) m/s of a rolling sphere (None: it
        rolls); plain: slide at ``self.friction[k]`` whatever the body (a settled cluster)."""
        body = self.bodies[k]
        if body.rolls and not plain:
            spin = (velocity[0], velocity[1]) if spin_velocity is None else spin_velocity
            seg = start_sphere_segment(t, position, velocity, spin, yaw, body.shape.rest_height,
                                       body.friction, body.rolling_friction, self.g)
        else:
            # Slide and spin coupled for cubes only: coupling cylinders too (their spin comes
            # from friction alone) made identification on exact tracks converge worse (docs/engine.md).
            spin_arm = body.shape.footprint_mean_radius if body.shape.kind == "cube" else 0.0
            seg = start_segment(t, position, velocity, yaw, yaw_rate, body.shape.rest_height, self.friction[k], self.g,
                                spin_arm, body.shape.yaw_inertia_per_mass)
        self.segments[k] = seg
        self.logs[k].append(seg)

    def _handle_body_event(self, k: int, t: float) -> None:
        body = self.bodies[k]
        if self.status[k] == "pending":
            self.status[k] = "active"
            init = body.initial
            self._set_segment(k, t, init.position, init.velocity, init.yaw, init.yaw_rate, init.spin_velocity)
            return
        seg = self.segments[k]
        position, velocity, yaw, yaw_rate = seg.state_at(t)
        if body.active_until is not None and t >= body.active_until:
            self.status[k] = "gone"
            self.segments[k] = None
            self.logs[k].append(inactive_segment(t, position, yaw))
            return
        if seg.mode == FLIGHT:  # landing: plastic impact with the plane (vz -> 0), then slide
            self.friction[k] = body.friction
            self._set_segment(k, t, (position[0], position[1], body.shape.rest_height),
                              (velocity[0], velocity[1], 0.0), yaw, yaw_rate, seg.spin_velocity_at(t))
            return
        if seg.mode == SKID:  # the contact point stops slipping: the sphere rolls on (no event)
            self._set_segment(k, t, position, velocity, yaw, 0.0)
            return
        # Coulomb stop: exactly at rest from now on (a body that only spun in place did not move: no event).
        self._set_segment(k, t, position, (0.0, 0.0, 0.0), yaw, 0.0)
        if seg.velocity[0] == 0.0 and seg.velocity[1] == 0.0:
            return
        self._record(t, Event("stop", (body.id,), t, frame_of(t, self.world.fps), tuple(position), 0.0))

    # ------------------------------------------------------------------ contacts
    def _motion(self, k: int, t: float) -> PlanarMotion:
        seg = self.segments[k]
        p, v, yaw, w = seg.state_at(t)
        tau_end = seg.end - t
        # A sliding segment's yaw decelerates; keep its acceleration (valid until seg.end).
        return PlanarMotion(self.footprints[k], (p[0], p[1]), (v[0], v[1]),
                            (seg.acceleration[0], seg.acceleration[1]), yaw, w,
                            seg.yaw_accel if tau_end > 0 else 0.0)

    def _predict(self, a: int, b: int, t: float) -> None:
        key = (a, b)
        self.pred.pop(key, None)
        if not self.contacts_enabled or self.status[a] != "active" or self.status[b] != "active":
            return
        sa, sb = self.segments[a], self.segments[b]
        if sa.mode == REST and sb.mode == REST:
            return
        window_end = min(self._body_next(a), self._body_next(b), self.t_end)
        if window_end < t:
            return
        flow_end = min(sa.end, sb.end)
        contact = predict_contact(self._motion(a, t), self._motion(b, t), window_end - t,
                                  flow_end - t if math.isfinite(flow_end) else None)
        if contact is not None:
            self.pred[key] = (t + contact.tau, contact)

    def _refresh_pairs(self, changed: Sequence[int], t: float) -> None:
        n = len(self.bodies)
        done = set()
        for k in changed:
            for other in range(n):
                if other == k:
                    continue
                key = (min(k, other), max(k, other))
                if key not in done:
                    done.add(key)
                    self._predict(key[0], key[1], t)

    def _restitution(self, a: int, b: int) -> float:
        ia, ib = self.bodies[a].id, self.bodies[b].id
        return self.pair_e.get((min(ia, ib), max(ia, ib)),
                               min(self.bodies[a].restitution, self.bodies[b].restitution))

    def _collide(self, a: int, b: int, t: float, contact) -> list[int]:
        body_a, body_b = self.bodies[a], self.bodies[b]
        pa, va, yaw_a, wa = self.segments[a].state_at(t)
        pb, vb, yaw_b, wb = self.segments[b].state_at(t)
        # An impulse changes a sphere's velocity, not its spin (it skids afterwards).
        spin_a, spin_b = self.segments[a].spin_velocity_at(t), self.segments[b].spin_velocity_at(t)
        nx, ny = contact.normal  # from b to a
        own_a, own_b = self._yaw_rate_of(a, wa), self._yaw_rate_of(b, wb)
        # The impulse acts at the contact patch's centre: off the centre line of a cube, it spins it.
        point, ends = contact_patch(self.footprints[a], pa[0], pa[1], yaw_a,
                                    self.footprints[b], pb[0], pb[1], yaw_b, (nx, ny), contact.point)
        centres = ((pa[0], pa[1]), (pb[0], pb[1]))
        # The patch closes where it closes fastest: its centre, or an end a spin turns inwards.
        vn = min(contact_normal_speed((nx, ny), at, centres, ((va[0], va[1]), (vb[0], vb[1])), (own_a, own_b))
                 for at in (point, *ends))
        ids = tuple(sorted((body_a.id, body_b.id)))
        height = 0.5 * (pa[2] + pb[2])
        sa, sb = self.segments[a], self.segments[b]
        an = (sa.acceleration[0] - sb.acceleration[0]) * nx + (sa.acceleration[1] - sb.acceleration[1]) * ny
        if not closing(vn, an):
            # Nothing to resolve (rounding, or a corner sweeping past while the contact points
            # separate): keep both flows. Without spin (or between two circles, whose gap spin
            # does not change), do not predict this pair again until one of them changes (no
            # zero-time loop); a spinning pair is searched again when a corner could come back.
            circles = self.footprints[a].kind == CIRCLE and self.footprints[b].kind == CIRCLE
            if (own_a == 0.0 and own_b == 0.0) or circles:
                self.pred.pop((a, b), None)
            else:
                window = min(self._body_next(a), self._body_next(b), self.t_end) - t
                step = clearance_step(self._motion(a, t), self._motion(b, t), 0.0, window)
                self.pred[(a, b)] = (t + step, Contact(step, None, contact.point))
            return []
        ma, mb = body_a.mass, body_b.mass
        key = (a, b)
        recent = [tc for tc in self.last_collision.get(key, []) if t - tc < ZENO_INTERVAL]
        settle = -vn < SETTLE_SPEED or len(recent) >= ZENO_REPEATS
        self.last_collision[key] = recent + [t]
        if settle:
            members = self._touching_cluster(a, b, t)
            impulse = self._settle(members, t, a)
        else:
            members = [a, b]
            mu = pair_friction(body_a.contact_friction, body_b.contact_friction)
            # A rolling sphere's equator moves vertically at spin . n (a) or -spin . n (b):
            # vertical friction at the contact changes its rolling spin (r^2 / I per unit mass).
            roll_a, roll_b = self._spin_compliance(a), self._spin_compliance(b)
            vertical_slip = ((spin_a[0] * nx + spin_a[1] * ny) if roll_a else 0.0) + \
                ((spin_b[0] * nx + spin_b[1] * ny) if roll_b else 0.0)
            response = collision_impulse(
                (nx, ny), point, centres, ((va[0], va[1]), (vb[0], vb[1])), (own_a, own_b), (ma, mb),
                (ma * body_a.shape.yaw_inertia_per_mass, mb * body_b.shape.yaw_inertia_per_mass),
                self._restitution(a, b), mu, self.world.contact_slip_removal, vertical_slip,
                roll_a / ma + roll_b / mb, ends if ends[0] != ends[1] else ())
            impulse = response.normal_impulse
            dva, dvb = response.velocity_change_i, response.velocity_change_j
            new_va = (va[0] + dva[0], va[1] + dva[1], va[2])
            new_vb = (vb[0] + dvb[0], vb[1] + dvb[1], vb[2])
            yaw_rate_a = self._yaw_rate_of(a, own_a + response.yaw_rate_change_i)
            yaw_rate_b = self._yaw_rate_of(b, own_b + response.yaw_rate_change_j)
            jz = response.friction.vertical if response.friction is not None else 0.0
            if roll_a:
                spin_a = (spin_a[0] + roll_a * jz / ma * nx, spin_a[1] + roll_a * jz / ma * ny)
            if roll_b:
                spin_b = (spin_b[0] + roll_b * jz / mb * nx, spin_b[1] + roll_b * jz / mb * ny)
            self.friction[a], self.friction[b] = body_a.friction, body_b.friction
            self._set_segment(a, t, pa, new_va, yaw_a, yaw_rate_a, spin_a)
            self._set_segment(b, t, pb, new_vb, yaw_b, yaw_rate_b, spin_b)
        self._record(t, Event("collision", ids, t, frame_of(t, self.world.fps),
                              (contact.point[0], contact.point[1], height), float(impulse)))
        return members

    def _spin_compliance(self, k: int) -> float:
        """m r^2 / I (dimensionless) of body k's rolling spin about a horizontal axis: a rolling
        sphere's (2.5 for a solid one); 0 for bodies whose spin is not tracked."""
        body = self.bodies[k]
        return body.shape.radius**2 / body.shape.yaw_inertia_per_mass if body.rolls else 0.0

    def _yaw_rate_of(self, k: int, yaw_rate: float) -> float:
        """The yaw rate body k carries: a sphere's spin about z is not tracked (its footprint
        and its rolling do not depend on it), so it is 0 for spheres."""
        return 0.0 if self.bodies[k].shape.kind == "sphere" else yaw_rate

    def _touching_cluster(self, a: int, b: int, t: float) -> list[int]:
        """a, b and every body linked to them by a touching pair that collided within ZENO_INTERVAL."""
        members, frontier = [a, b], [a, b]
        while frontier:
            k = frontier.pop()
            for other in range(len(self.bodies)):
                if other in members or self.status[other] != "active":
                    continue
                key = (min(k, other), max(k, other))
                if not any(t - tc < ZENO_INTERVAL for tc in self.last_collision.get(key, ())):
                    continue
                pk, _, yk, _ = self.segments[k].state_at(t)
                po, _, yo, _ = self.segments[other].state_at(t)
                gap, _, _ = footprint_distance(self.footprints[k], pk[0], pk[1], yk,
                                               self.footprints[other], po[0], po[1], yo)
                if gap <= CLUSTER_GAP:
                    members.append(other)
                    frontier.append(other)
        return members

    def _settle(self, members: list[int], t: float, reference: int) -> float:
        """Give a jammed cluster its common momentum velocity and mass-weighted friction.

        Perfectly inelastic (kinetic energy can only drop), momentum conserved.
        Returns the impulse magnitude (N s) received by ``reference``.
        """
        states = {k: self.segments[k].state_at(t) for k in members}
        masses = {k: self.bodies[k].mass for k in members}
        total = sum(masses.values())
        vx = sum(masses[k] * states[k][1][0] for k in members) / total
        vy = sum(masses[k] * states[k][1][1] for k in members) / total
        shared = sum(masses[k] * self.bodies[k].sliding_deceleration_coefficient for k in members) / total
        ref_v = states[reference][1]
        impulse = masses[reference] * math.hypot(vx - ref_v[0], vy - ref_v[1])
        for k in members:
            position, velocity, yaw, yaw_rate = states[k]
            self.friction[k] = shared
            self._set_segment(k, t, position, (vx, vy, velocity[2]), yaw, 0.0, plain=True)
        return impulse

    def _apply_anchor(self, t: float) -> None:
        """Reset the anchored bodies that are active now to their anchor states."""
        index = {body.id: k for k, body in enumerate(self.bodies)}
        reset = []
        for body_id, state in self.anchor.states:
            k = index[body_id]
            if self.status[k] != "active":
                continue  # not entered yet, or removed: nothing to re-anchor
            self.friction[k] = self.bodies[k].friction
            self._set_segment(k, t, state.position, state.velocity, state.yaw, state.yaw_rate, state.spin_velocity)
            reset.append(k)
        self.anchor = None
        self.last_collision.clear()
        self._refresh_pairs(reset, t)

    def _record(self, t: float, event: Event) -> None:
        self.events.append((t, len(self.events), event))

    # ------------------------------------------------------------------ loop
    def run(self) -> None:
        n = len(self.bodies)
        t = 0.0
        # Bodies present at t = 0 start together; later ones enter through body events.
        starters = [k for k in range(n) if self.bodies[k].initial.time <= 0.0]
        for k in starters:
            self._handle_body_event(k, 0.0)
        self._refresh_pairs(starters, 0.0)
        while True:
            body_k, body_t = -1, math.inf
            for k in range(n):
                tk = self._body_next(k)
                if tk < body_t:
                    body_k, body_t = k, tk
            pair_key, pair_t = None, math.inf
            for key, (tp, _) in self.pred.items():
                if tp < pair_t:
                    pair_key, pair_t = key, tp
            anchor_t = self.anchor.time if self.anchor is not None else math.inf
            t_next = min(body_t, pair_t, anchor_t)
            if t_next > self.t_end:
                break
            t = t_next
            if anchor_t <= min(body_t, pair_t):
                self._apply_anchor(t)
                continue
            self.event_count += 1
            if self.event_count > MAX_EVENTS and self.contacts_enabled:
                self.contacts_enabled = False
                self.pred.clear()
                self.notes.append(f"event cap {MAX_EVENTS} reached at t={t:.6g} s; later contacts ignored")
                continue
            if body_t <= pair_t:  # body events first on ties (a stop changes the pair flows)
                self._handle_body_event(body_k, t)
                self._refresh_pairs([body_k], t)
            else:
                a, b = pair_key
                contact = self.pred[pair_key][1]
                if contact.normal is None:  # search budget ran out: continue the search from here
                    self._predict(a, b, t)
                    continue
                self._refresh_pairs(self._collide(a, b, t, contact), t)
        for k in range(n):
            if not self.logs[k]:  # never entered within the horizon
                init = self.bodies[k].initial
                self.logs[k].append(inactive_segment(init.time, init.position, init.yaw))


def _apart_for_gap(world: World, logs: Sequence[list[Segment]], pair: tuple[int, ...], t0: float, t1: float) -> bool:
    """Whether the pair stays apart (footprint gap > EPISODE_TOUCH_GAP) for CONTACT_EPISODE_GAP s
    without a break somewhere in (t0, t1), probed every EPISODE_PROBE_STEP on the exact flows."""
    if t1 - t0 <= CONTACT_EPISODE_GAP:
        return False
    index = {b.id: k for k, b in enumerate(world.bodies)}
    fa, fb = (footprint_of(world.bodies[index[b]]) for b in pair)
    needed = int(math.ceil(CONTACT_EPISODE_GAP / EPISODE_PROBE_STEP))
    apart_run = 0
    start = t0 + EPISODE_PROBE_STEP
    while start < t1:
        times = np.arange(start, min(t1, start + 64 * EPISODE_PROBE_STEP), EPISODE_PROBE_STEP)
        (pa, _, ya, _), (pb, _, yb, _) = (evaluate_segments(logs[index[b]], times) for b in pair)
        for k in range(len(times)):
            gap = footprint_distance(fa, pa[k, 0], pa[k, 1], ya[k], fb, pb[k, 0], pb[k, 1], yb[k])[0]
            apart_run = apart_run + 1 if gap > EPISODE_TOUCH_GAP else 0
            if apart_run >= needed:
                return True
        start = float(times[-1]) + EPISODE_PROBE_STEP
    return False


def merge_contact_episodes(
    events: Sequence[Event],
    gap: float = CONTACT_EPISODE_GAP,
    apart: Callable[[tuple[int, ...], float, float], bool] | None = None,
) -> list[Event]:
    """One collision event per contact episode of a pair.

    A push, a rattle or a body sliding along another is several impulses;
    CLEVRER (and the scene generator's MuJoCo ground truth) count it as one
    collision: a pair collides anew only after ``gap`` seconds without
    contact. A pair's collision that follows its previous one without
    ``gap`` seconds apart in between joins that episode: the first event
    stays, with the summed impulse. ``apart(pair, t0, t1)``: whether the
    pair was apart for ``gap`` seconds within (t0, t1) (default: t1 - t0 >
    gap, i.e. the touch ends at the collision).
    events: in time order. Returns a new list in time order.
    """
    merged: list[Event] = []
    last: dict[tuple[int, ...], tuple[int, float]] = {}
    for event in events:
        if event.kind != "collision":
            merged.append(event)
            continue
        previous = last.get(event.bodies)
        if previous is not None and not (event.time - previous[1] > gap if apart is None else apart(event.bodies, previous[1], event.time)):
            index = previous[0]
            first = merged[index]
            merged[index] = Event(first.kind, first.bodies, first.time, first.frame, first.position, first.impulse + event.impulse)
            last[event.bodies] = (index, event.time)
            continue
        last[event.bodies] = (len(merged), event.time)
        merged.append(event)
    return merged


def simulate(
    world: World,
    edits: Sequence[Edit] = (),
    horizon_frames: int | None = None,
    rollout_id: str = "base",
) -> Rollout:
    """Execute ``world`` after ``edits`` for ``horizon_frames`` frames at ``world.fps``.

    horizon_frames: default ``ceil(observed_frames * 1.2)``. Returns a Rollout with
    per-frame positions (T, N, 3) m, velocities (T, N, 3) m/s, yaw (T, N) rad,
    active/visible (T, N) bool and the events (collision, stop, in, out) in time
    order. Raises ValueError (naming the field) for invalid input.
    """
    if not isinstance(world, World):
        raise ValueError(f"world: expected a world.types.World, got {type(world).__name__}")
    edits = tuple(edits)
    for position, edit in enumerate(edits):
        if not isinstance(edit, Edit):
            raise ValueError(f"edits[{position}]: expected a world.types.Edit, got {type(edit).__name__}")
    if horizon_frames is None:
        horizon_frames = default_horizon(world)
    if isinstance(horizon_frames, bool) or not isinstance(horizon_frames, (int, np.integer)) or horizon_frames < 1:
        raise ValueError(f"horizon_frames: expected an integer >= 1, got {horizon_frames!r}")
    if horizon_frames > 1_000_000:
        raise ValueError(f"horizon_frames: at most 1000000 frames, got {horizon_frames}")
    if not isinstance(rollout_id, str) or not rollout_id:
        raise ValueError(f"rollout_id: expected a non-empty string, got {rollout_id!r}")
    edited = apply_edits(world, edits)
    _validate_initial_overlaps(edited)

    fps = edited.fps
    horizon_frames = int(horizon_frames)
    # The anchor re-starts the factual continuation only: an edited world is
    # another history and replays from the initial states.
    engine = _Engine(edited, t_end=(horizon_frames - 1) / fps, use_anchor=not edits)
    engine.run()

    times = np.arange(horizon_frames, dtype=float) / fps
    n = len(edited.bodies)
    positions = np.zeros((horizon_frames, n, 3))
    velocities = np.zeros((horizon_frames, n, 3))
    yaw = np.zeros((horizon_frames, n))
    yaw_rates = np.zeros((horizon_frames, n))
    active = np.zeros((horizon_frames, n), dtype=bool)
    visible = np.zeros((horizon_frames, n), dtype=bool)
    for k, body in enumerate(edited.bodies):
        p, v, y, act = evaluate_segments(engine.logs[k], times)
        positions[:, k], velocities[:, k], yaw[:, k], active[:, k] = p, v, y, act
        yaw_rates[:, k] = evaluate_yaw_rates(engine.logs[k], times)
        if edited.camera is None:
            visible[:, k] = act
        else:
            visible[:, k] = act & centre_in_view(edited.camera, p)

    events = merge_contact_episodes([e for _, _, e in sorted(engine.events, key=lambda item: (item[0], item[1]))],
                                    apart=lambda pair, t0, t1: _apart_for_gap(edited, engine.logs, pair, t0, t1))
    for kind, k, frame in view_events(visible, active):
        body = edited.bodies[k]
        events.append(Event(kind, (body.id,), frame / fps, frame, tuple(float(x) for x in positions[frame, k]), 0.0))
    events.sort(key=lambda e: (e.time, {"collision": 0, "stop": 1, "in": 2, "out": 3}[e.kind]))

    return Rollout(
        id=rollout_id,
        world_id=world.id,
        edits=edits,
        fps=fps,
        observed_frames=edited.observed_frames,
        body_ids=edited.body_ids,
        times=times,
        positions=positions,
        velocities=velocities,
        yaw=yaw,
        active=active,
        visible=visible,
        events=tuple(events),
        notes=tuple(engine.notes),
        yaw_rates=yaw_rates,
    )
