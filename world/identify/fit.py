"""System identification: observations -> a fitted, executable World.

Stages (paper Sec. 3.3 and Appendix A.2, in our words):

1. Candidate collisions from proximity + velocity change (segments.py).
2. Local closed-form slide fits on every collision-free stretch of every
   track (local_fit.py): initial position and velocity, friction.
3. Collision response from the observed velocity jumps: mass ratios per
   contact-connected component (one reference mass each, absolute scale
   from a per-material prior) and restitution per colliding pair.
4. Joint refinement, per contact-connected component, of initial states,
   friction, mass ratios and restitution against the event-driven rollout
   with cumulative temporal prefixes (each stage extends the horizon past the
   next collision and starts from the previous best).
5. Re-anchoring: the continuation past the observed window starts from the
   state fitted on each body's last stretch (see docs/identification.md).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace
from typing import Callable, Mapping, Sequence

import numpy as np
from scipy.optimize import least_squares
from threadpoolctl import threadpool_limits

from world.contacts import footprint_distance
from world.footprint import footprint_gap
from world.identify.graph import connected_components
from world.identify.jacobian import SecantJacobian
from world.identify.materials import MaterialRevision, REPORT_CHANGE, prior_mass, revise_materials
from world.identify.local_fit import MIN_FRICTION_SAMPLES, MU_BOUNDS, SlideFit, fit_slide, late_departure, robust_residuals, tail_state
from world.identify.segments import (MIN_REST_SAMPLES, CandidateCollision, contact_episode_starts, find_candidate_collisions,
                                     precise_tracks, seen_touching, unexplained_start)
from world.observations import ObjectTrack, Observations
from world.rollout import footprint_of, simulate
from world.timebase import CONTACT_EPISODE_GAP_SECONDS, frames_in
from world.types import STANDARD_GRAVITY, Anchor, Body, BodyState, World

MASS_RATIO_BOUNDS = (0.05, 20.0)  # paper, Appendix A: 0.05 < m_i / m_j < 20
SKID_FRICTION_BOUNDS = (0.05, 1.5)  # kinetic friction of a skidding sphere
RESTITUTION_BOUNDS = (0.02, 0.99)  # open interval (0, 1), kept off the edges


@dataclass(frozen=True)
class FitConfig:
    """Knobs of the identification; defaults are the measured best (docs/benchmarks.md)."""

    gravity: float = STANDARD_GRAVITY
    friction_prior: float = 0.3
    # Spheres skid after a collision, then roll (docs/engine.md): their fitted
    # deceleration is the rolling resistance, and the kinetic (skid) friction
    # starts from this prior (hard rubber or metal on a hard floor, 0.3-0.5)
    # and is refined by the joint fit for spheres in collisions. Off by
    # default: on 40 fresh scenes it fitted worse than sliding spheres in the
    # same run (+3 s median 11.2 vs 8.4 cm, RMSE p95 17 vs 9 cm), and again
    # with friction between bodies on 40 other fresh scenes (+3 s median 14.1
    # vs 11.5 cm; docs/benchmarks.md, "Issue 13, motion modes").
    rolling_spheres: bool = False
    skid_friction_prior: float = 0.4
    # Friction between bodies at impacts (docs/engine.md, "Collision response"):
    # a body's surface is taken to rub on another as on the floor (its fitted
    # sliding friction; a sphere's skid friction), and an impact removes
    # this share of the contact points' slip, as MuJoCo's soft contact does
    # (bench/bench_contact_friction.py). False: frictionless contacts.
    friction_between_bodies: bool = True
    contact_slip_removal: float = 0.45
    restitution_prior: float = 0.8
    # Semantic prior for masses across unconnected components: density
    # (kg/m^3) by material times the volume of the known shape. Rubber is
    # about 1100; "metal" is taken as aluminium, the lightest common metal.
    density_prior: Mapping[str, float] = field(default_factory=lambda: {"rubber": 1100.0, "metal": 2700.0})
    # The same densities read the other way: a perceived body's material belief
    # is revised by the mass ratios its collisions identified (world/identify/materials.py;
    # docs/identification.md). Off for worlds whose materials all weigh the same.
    materials_from_masses: bool = True
    joint: bool = True
    prefix_margin_frames: int = 10
    # What a stage may fit needs enough video after the event that informs it.
    # A collision's restitution is fitted only by stages that see at least
    # restitution_after_seconds after it (0.16 s: 4 frames at 25 fps), and the
    # sliding friction of a body only by stages that see it move for at least
    # friction_after_seconds (0.4 s: a deceleration needs longer than a
    # velocity) since it was first seen moving or set moving by its first
    # collision. A contact in the video's last frames shows almost nothing of
    # the response: the optimiser bent e to its bound, or the struck body's
    # friction up to 1, to fit one or two samples, and the continuation after
    # the video went wrong. Until then they keep their estimates (the median
    # restitution of the informed pairs; the similar objects' friction).
    # Masses need less: two samples of the struck body after the collision
    # (mass_after_seconds) show the momentum it took. Chosen on development
    # scenes (docs/benchmarks.md, "Issue 13, the response to a late collision").
    restitution_after_seconds: float = 0.16
    friction_after_seconds: float = 0.4
    mass_after_seconds: float = 0.08
    max_nfev_per_stage: int = 60
    # Relative cost change that ends a stage: millimetre-level changes of an
    # RMSE of a few millimetres do not change any event.
    tolerance: float = 1e-4
    # Near the noise floor (stall_floor_multiple below), a stage also ends when
    # an iteration lowers its cost by less than this share (2 % of the cost is
    # 1 % of the RMSE): such tails of slow iterations cost most of the
    # forward-difference rollouts (docs/benchmarks.md). Also the share below
    # which a step from a secant Jacobian asks for a fresh forward difference.
    min_relative_improvement: float = 0.02
    # A stage ends (or is skipped) once its RMSE is at the noise floor: this
    # factor times the pooled RMSE of the component's local closed-form fits
    # (the frames next to a contact, which the local fits leave out, are
    # never fitted as well). Relative only: exact tracks have no floor.
    noise_floor_factor: float = 1.1
    # ... and the early stop on slow iterations applies only at an RMSE up to
    # this many noise floors: a slow step further up can be a plateau before
    # a contact the replay does not make yet (exact tracks: never).
    stall_floor_multiple: float = 1.5
    # Jacobians of the joint fit: forward differences at a stage's start and
    # after a stalled step, Broyden updates in between (world/identify/jacobian.py);
    # False: a forward difference every iteration (scipy's '2-point').
    secant_jacobian: bool = True
    # The joint fit's replay must make every contact the track analysis saw by
    # geometry (two precise tracks, segments.touch_events) and no other
    # contact of those pairs: contact residuals (_contact_residuals) beside
    # the positions. Off by default: on 70 development scenes (seeds 31337,
    # 27182) the replay reproduced fewer of MuJoCo's collisions with it
    # (recall 0.955 / 0.936) than without (0.955 / 0.960; docs/benchmarks.md).
    reproduce_contacts: bool = False
    # Bodies seen on fewer frames than this get conservative defaults.
    min_frames: int = 2
    # CPU seconds (of the fitting process) for the joint refinement of the
    # whole scene. When they run out, the stage being fitted keeps its best
    # vector so far, the remaining stages are skipped, and the report says so
    # (budget_exhausted). CPU, not wall clock: on the shared machine a wall
    # budget cut 17 of 40 fits at 1-2 CPU seconds each (docs/benchmarks.md),
    # and the fitted world should not depend on the machine's load. 12 s: a
    # 3 s budget meets the p95 of 4 CPU seconds but lost accuracy on
    # noisy tracks (predictive F1 0.483 vs 0.523 at 3 % noise, docs/benchmarks.md),
    # and the cost target is "at equal or better accuracy"; pass a smaller
    # FitConfig.time_budget_seconds (bench_identify --budget) to trade accuracy for time.
    time_budget_seconds: float = 12.0
    # simulate(world, edits, horizon_frames) -> Rollout; None: the
    # event-driven engine (a fixed-step baseline plugs in here).
    simulator: Callable[..., object] | None = None


@dataclass(frozen=True)
class ObjectFitReport:
    id: int
    rmse: float
    observed_frames: int
    identified: tuple[str, ...]
    defaulted: Mapping[str, str]
    flags: tuple[str, ...] = ()


@dataclass(frozen=True)
class FitReport:
    objects: tuple[ObjectFitReport, ...]
    collisions_used: tuple[tuple[int, int, int], ...]  # (id_a, id_b, frame)
    components: tuple[tuple[int, ...], ...]
    stages: int
    function_evaluations: int
    seconds: float  # wall clock of the whole fit
    rmse: float  # metres, over every observed sample of every object
    cpu_seconds: float = 0.0  # this process's CPU seconds for the whole fit: the clock of the budget
    budget_exhausted: bool = False  # the joint refinement stopped at FitConfig.time_budget_seconds
    skipped_stages: int = 0  # stages cut short or skipped because the budget ran out

    def to_dict(self) -> dict[str, object]:
        return {
            "objects": [
                {
                    "id": o.id,
                    "rmse": None if math.isnan(o.rmse) else o.rmse,  # None: never observed
                    "observed_frames": o.observed_frames,
                    "identified": list(o.identified),
                    "defaulted": dict(o.defaulted),
                    "flags": list(o.flags),
                }
                for o in self.objects
            ],
            "collisions_used": [list(c) for c in self.collisions_used],
            "components": [list(c) for c in self.components],
            "stages": self.stages,
            "function_evaluations": self.function_evaluations,
            "seconds": self.seconds,
            "cpu_seconds": self.cpu_seconds,
            "rmse": self.rmse,
            "budget_exhausted": self.budget_exhausted,
            "skipped_stages": self.skipped_stages,
        }


# --------------------------------------------------------------------------
# Stage 2: per-track stretches
# --------------------------------------------------------------------------
@dataclass(frozen=True)
class TrackFit:
    """Slide fits of one track's collision-free stretches, in time order."""

    track: ObjectTrack
    stretches: tuple[SlideFit, ...]
    breakpoints: tuple[int, ...]  # frames of the collisions that split the track


def _fit_stretches(
    track: ObjectTrack, breakpoints: Sequence[int], fps: float, config: FitConfig
) -> TrackFit:
    """Split at collision frames (dropping one frame each side) and fit each piece."""
    observed = track.observed
    edges = [int(track.frames[observed][0]) - 1, *sorted(breakpoints), int(track.frames[observed][-1]) + 1]
    fits: list[SlideFit] = []
    for index, (low, high) in enumerate(zip(edges[:-1], edges[1:])):
        # Frames right next to a contact are blurred by its finite duration
        # and by the frame quantisation of the contact time. The track's own
        # last sample is dropped too (keeping it moved answers from video:
        # docs/benchmarks.md, thirty-fifth round), unless the last stretch
        # would keep fewer than two: a body seen on the video's last two
        # frames only keeps both, and with them its velocity.
        after_low = observed & (track.frames > low + (1 if fits else 0))
        inside = after_low & (track.frames < high - 1)
        if index == len(edges) - 2 and inside.sum() < 2:
            inside = after_low & (track.frames < high)
        if inside.sum() == 0:
            inside = observed & (track.frames > low) & (track.frames < high)
        if inside.sum() == 0:
            continue
        fits.append(
            fit_slide(
                track.frames[inside] / fps,
                track.positions[inside, :2],
                track.weights[inside],
                config.gravity,
                config.friction_prior,
            )
        )
    return TrackFit(track, tuple(fits), tuple(sorted(breakpoints)))


def _friction_estimate(fit: TrackFit, weak: bool = False) -> float | None:
    """Sample-weighted geometric mean friction of the stretches that showed deceleration; ``weak``: of the
    moving stretches of at least MIN_FRICTION_SAMPLES samples whose deceleration was too small a share of
    their speed to count as identified (a short launch before a contact: a fair reading, not a sure one)."""
    def counted(stretch: SlideFit) -> bool:
        if weak:
            return not stretch.friction_identified and stretch.samples >= MIN_FRICTION_SAMPLES
        return stretch.friction_identified

    values = [(s.friction, s.samples) for s in fit.stretches if np.hypot(*s.velocity) > 0 and counted(s)]
    if not values:
        return None
    mus, counts = zip(*values)
    return float(np.exp(np.average(np.log(mus), weights=counts)))


# --------------------------------------------------------------------------
# Stage 3: collision response from velocity jumps
# --------------------------------------------------------------------------
def _response_estimates(
    candidates: Sequence[CandidateCollision],
) -> tuple[list[tuple[int, int, float]], dict[tuple[int, int], float]]:
    """Per candidate: log mass ratio log(m_a / m_b) and restitution, where informative.

    Momentum along the normal n: m_a dv_a.n = -m_b dv_b.n, and the
    restitution law (v_a' - v_b').n = -e (v_a - v_b).n.
    """
    log_ratios: list[tuple[int, int, float]] = []
    restitution: dict[tuple[int, int], list[float]] = {}
    for c in candidates:
        if not (np.all(np.isfinite(c.pre)) and np.all(np.isfinite(c.post))):
            continue  # one side unseen: the jump says nothing about the response
        n = c.normal
        dva, dvb = c.delta_v[0] @ n, c.delta_v[1] @ n
        # a is pushed back (-n), b forward (+n) in a genuine impulse.
        if dva < -0.05 and dvb > 0.05:
            ratio = float(np.clip(-dvb / dva, *MASS_RATIO_BOUNDS))
            log_ratios.append((c.bodies[0], c.bodies[1], math.log(ratio)))
        approach = (c.pre[0] - c.pre[1]) @ n
        if approach > 0.1:
            e = -((c.post[0] - c.post[1]) @ n) / approach
            restitution.setdefault(c.bodies, []).append(float(np.clip(e, *RESTITUTION_BOUNDS)))
    return log_ratios, {pair: float(np.median(v)) for pair, v in restitution.items()}


def _solve_masses(
    component: Sequence[int],
    log_ratios: Sequence[tuple[int, int, float]],
    priors: Mapping[int, float],
) -> tuple[dict[int, float], set[int]]:
    """Least-squares log masses from pairwise log ratios; scale from the prior masses.

    priors: body id -> prior mass (kg). Returns masses (kg) and the set of
    ids whose mass ratio was identified.
    """
    index = {body: k for k, body in enumerate(component)}
    rows, rhs = [], []
    identified: set[int] = set()
    for a, b, value in log_ratios:
        if a in index and b in index:
            row = np.zeros(len(component))
            row[index[a]], row[index[b]] = 1.0, -1.0
            rows.append(row)
            rhs.append(value)
            identified.update((a, b))
    prior_log = np.array([math.log(priors[body]) for body in component])
    # Weak pull to the prior fixes the free scale (and any unconnected member).
    weight = 1e-3
    matrix = np.vstack([*rows, weight * np.eye(len(component))]) if rows else weight * np.eye(len(component))
    target = np.concatenate([rhs, weight * prior_log]) if rows else weight * prior_log
    log_mass, *_ = np.linalg.lstsq(matrix, target, rcond=None)
    # Keep ratios inside the bounds relative to the component's reference (first) body.
    log_mass = log_mass[0] + np.clip(log_mass - log_mass[0], *np.log(MASS_RATIO_BOUNDS))
    return {body: float(math.exp(log_mass[index[body]])) for body in component}, identified


# --------------------------------------------------------------------------
# Assembling a World from per-body estimates
# --------------------------------------------------------------------------
@dataclass(frozen=True)
class BodyEstimate:
    """Current estimate for one body (all SI): entry state and parameters."""

    track: ObjectTrack
    start_time: float
    position: np.ndarray  # (2,) metres at start_time
    velocity: np.ndarray  # (2,) m/s at start_time
    yaw: float
    friction: float
    mass: float
    restitution: float
    # Seen at rest long enough before its first contact: velocity stays 0.
    rest_start: bool = False
    # Spheres with the rolling model: kinetic friction while the contact point slips;
    # ``friction`` is then the rolling resistance (deceleration / g while rolling).
    skid_friction: float | None = None


def _body(estimate: BodyEstimate, config: FitConfig) -> Body:
    track = estimate.track
    rolls = estimate.skid_friction is not None
    contact_friction = None
    if config.friction_between_bodies:
        contact_friction = (estimate.skid_friction if rolls else config.skid_friction_prior) \
            if track.shape.kind == "sphere" else estimate.friction
    return Body(
        id=track.id,
        shape=track.shape,
        initial=BodyState(
            position=(float(estimate.position[0]), float(estimate.position[1]), track.shape.rest_height),
            velocity=(float(estimate.velocity[0]), float(estimate.velocity[1]), 0.0),
            yaw=estimate.yaw,
            time=estimate.start_time,
        ),
        mass=estimate.mass,
        friction=estimate.skid_friction if rolls else estimate.friction,
        rolling_friction=estimate.friction if rolls else None,
        restitution=estimate.restitution,
        color=track.color,
        material=track.material,
        contact_friction=contact_friction,
        attribute_belief=track.attribute_belief,
    )


# Bodies entering together must not overlap (the engine rejects it); noisy
# tracks of touching objects, or an optimiser step, can make them overlap a
# little. They are pushed apart along the contact normal, to this gap (m).
SEPARATION_GAP = 1e-5


def _separated(bodies: tuple[Body, ...], passes: int = 20) -> tuple[Body, ...]:
    """Move apart bodies that enter at the same time with overlapping footprints (minimal, symmetric)."""
    positions = [list(b.initial.position) for b in bodies]
    moved = False
    for _ in range(passes):
        clean = True
        for a in range(len(bodies)):
            for b in range(a + 1, len(bodies)):
                if bodies[a].initial.time != bodies[b].initial.time:
                    continue
                gap, normal, _ = footprint_distance(
                    footprint_of(bodies[a]), positions[a][0], positions[a][1], bodies[a].initial.yaw,
                    footprint_of(bodies[b]), positions[b][0], positions[b][1], bodies[b].initial.yaw,
                )
                if gap >= 0:
                    continue
                push = 0.5 * (-gap + SEPARATION_GAP)
                for k, sign in ((a, 1.0), (b, -1.0)):  # the normal points from b to a
                    positions[k][0] += sign * push * normal[0]
                    positions[k][1] += sign * push * normal[1]
                clean = False
                moved = True
        if clean:
            break
    if not moved:
        return bodies
    return tuple(
        replace(body, initial=replace(body.initial, position=tuple(position)))
        for body, position in zip(bodies, positions)
    )


def _world(
    estimates: Sequence[BodyEstimate],
    pair_restitution: Mapping[tuple[int, int], float],
    observations: Observations,
    config: FitConfig,
    provenance: Mapping[str, object] | None = None,
    with_camera: bool = True,
) -> World:
    """The World of these estimates. with_camera False: no camera (the joint fit's rollouts:
    only positions are compared, and the camera costs a visibility test per body and frame)."""
    return World(
        bodies=_separated(tuple(_body(e, config) for e in estimates)),
        fps=observations.fps,
        observed_frames=observations.num_frames,
        gravity=config.gravity,
        pair_restitution=tuple((a, b, float(e)) for (a, b), e in sorted(pair_restitution.items())),
        camera=observations.camera if with_camera else None,
        provenance=dict(provenance or {}),
        contact_slip_removal=config.contact_slip_removal,
    )


def _positions(
    world: World, horizon_frames: int, simulator: Callable[..., object] | None = None
) -> tuple[np.ndarray, np.ndarray, tuple[int, ...]]:
    """Simulated (T, N, 2) plane positions, (T, N) active mask and body order."""
    rollout = (simulator or simulate)(world, (), horizon_frames)
    return rollout.positions[:, :, :2], rollout.active, rollout.body_ids


# A recorded contact the replay must make: its residual is 0 when the replay
# has a collision of the pair within CONTACT_WINDOW frames of the recorded
# frame, else CONTACT_WEIGHT x the pair's smallest simulated footprint gap in
# that window (metres, like a position residual: it pulls the bodies
# together). A replayed collision of a pair whose contacts are all recorded
# (``decided_pairs``) that is not recorded pushes the pair apart: CONTACT_WEIGHT
# x how much closer than SPURIOUS_CLEARANCE its footprints come around it.
CONTACT_WINDOW = 3  # frames
CONTACT_WEIGHT = 3.0  # as many position samples as this squared
SPURIOUS_CLEARANCE = 0.01  # m


def _pair_gap(rollout, world: World, pair: tuple[int, int], frame: int) -> float:
    """Smallest simulated footprint gap (m) of ``pair`` within CONTACT_WINDOW frames of ``frame``; 0 if never both active."""
    column = {body_id: k for k, body_id in enumerate(rollout.body_ids)}
    frames = np.arange(max(frame - CONTACT_WINDOW, 0), min(frame + CONTACT_WINDOW + 1, rollout.horizon_frames))
    a, b = (column[i] for i in pair)
    frames = frames[rollout.active[frames, a] & rollout.active[frames, b]]
    if frames.size == 0:
        return 0.0
    return float(np.min(footprint_gap(world.body(pair[0]).shape, rollout.positions[frames, a], rollout.yaw[frames, a],
                                      world.body(pair[1]).shape, rollout.positions[frames, b], rollout.yaw[frames, b])))


def _contact_residuals(
    rollout, world: World, contacts: Sequence[tuple[tuple[int, int], int]], decided_pairs: Sequence[tuple[int, int]],
) -> np.ndarray:
    """(len(contacts) + len(decided_pairs),) metres: per recorded contact how far the replay is from making it,
    then per decided pair how far its unrecorded replayed collisions are from clearing (see CONTACT_WINDOW)."""
    made = [(tuple(sorted(e.bodies)), e.frame) for e in rollout.events if e.kind == "collision"]
    missing = np.zeros(len(contacts))
    for k, (pair, frame) in enumerate(contacts):
        if not any(p == pair and abs(f - frame) <= CONTACT_WINDOW for p, f in made):
            missing[k] = CONTACT_WEIGHT * max(_pair_gap(rollout, world, pair, frame), 0.0)
    spurious = np.zeros(len(decided_pairs))
    for k, pair in enumerate(decided_pairs):
        excess = [SPURIOUS_CLEARANCE - _pair_gap(rollout, world, pair, frame) for p, frame in made
                  if p == pair and not any(c == pair and abs(f - frame) <= CONTACT_WINDOW for c, f in contacts)]
        spurious[k] = CONTACT_WEIGHT * float(np.sqrt(np.sum(np.square(np.maximum(excess, 0.0))))) if excess else 0.0
    return np.concatenate([missing, spurious])


def _residuals(
    world: World, tracks: Sequence[ObjectTrack], horizon_frames: int, simulator: Callable[..., object] | None = None,
    contacts: Sequence[tuple[tuple[int, int], int]] = (), decided_pairs: Sequence[tuple[int, int]] = (),
) -> np.ndarray:
    """Weighted position residuals (metres; Huber-scaled beyond local_fit.ROBUST_SCALE) of every observed frame < horizon,
    then the contact residuals (``_contact_residuals``: recorded contacts at frames < horizon, decided pairs).

    Frames where the simulated body is not active count with the observed
    position against the body's entry position (keeps the vector length fixed).
    """
    rollout = (simulator or simulate)(world, (), horizon_frames)
    positions, active, order = rollout.positions[:, :, :2], rollout.active, rollout.body_ids
    column = {body_id: k for k, body_id in enumerate(order)}
    parts = []
    for track in tracks:
        use = track.observed & (track.frames < horizon_frames)
        frames = track.frames[use]
        simulated = positions[frames, column[track.id]]
        simulated = np.where(active[frames, column[track.id]][:, None], simulated, world.body(track.id).initial.position[:2])
        parts.append(((simulated - track.positions[use, :2]) * np.sqrt(track.weights[use])[:, None]).ravel())
    # Huber, not squares: a few far-off perceived frames must not drag the whole fit (local_fit.robust_residuals).
    positional = robust_residuals(np.concatenate(parts)) if parts else np.zeros(0)
    recorded = [c for c in contacts if c[1] < horizon_frames]
    return np.concatenate([positional, _contact_residuals(rollout, world, recorded, decided_pairs)])


# --------------------------------------------------------------------------
# Stage 4: joint refinement per contact-connected component
# --------------------------------------------------------------------------
@dataclass(frozen=True)
class _Packing:
    """How one component's parameters sit in the optimiser's vector.

    Layout: per body [x, y] (+ [vx, vy] unless the body starts at rest)
    + [log mu]; then log(m_i / m_ref) for the non-reference bodies; then
    restitution e per colliding pair. Bounds are box constraints on these
    transformed values (log keeps mu and masses positive; e stays in (0, 1)).
    A body seen at rest before its first contact keeps zero initial
    velocity: the data say so, and a free velocity only lets the optimiser
    trade it against friction.
    """

    bodies: tuple[int, ...]
    pairs: tuple[tuple[int, int], ...]
    moving: tuple[bool, ...]
    # Per body: a rolling sphere whose skid friction is fitted (one more entry, log mu_skid, last).
    skids: tuple[bool, ...] = ()

    def _skids(self) -> tuple[bool, ...]:
        return self.skids or (False,) * len(self.bodies)

    def _body_slots(self) -> list[tuple[int, int]]:
        slots, offset = [], 0
        for moving, skid in zip(self.moving, self._skids()):
            size = (5 if moving else 3) + (1 if skid else 0)
            slots.append((offset, size))
            offset += size
        return slots

    def pack(self, estimates: Mapping[int, BodyEstimate], pair_e: Mapping[tuple[int, int], float]) -> np.ndarray:
        reference = estimates[self.bodies[0]].mass
        values: list[float] = []
        for body, moving, skid in zip(self.bodies, self.moving, self._skids()):
            e = estimates[body]
            values += [*e.position, *(e.velocity if moving else ()), math.log(e.friction)]
            values += [math.log(e.skid_friction)] if skid else []
        values += [math.log(estimates[b].mass / reference) for b in self.bodies[1:]]
        values += [pair_e[p] for p in self.pairs]
        return np.asarray(values, dtype=np.float64)

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        low, high = [], []
        for moving, skid in zip(self.moving, self._skids()):
            free = 4 if moving else 2
            low += [-np.inf] * free + [math.log(MU_BOUNDS[0])] + ([math.log(SKID_FRICTION_BOUNDS[0])] if skid else [])
            high += [np.inf] * free + [math.log(MU_BOUNDS[1])] + ([math.log(SKID_FRICTION_BOUNDS[1])] if skid else [])
        low += [math.log(MASS_RATIO_BOUNDS[0])] * (len(self.bodies) - 1)
        high += [math.log(MASS_RATIO_BOUNDS[1])] * (len(self.bodies) - 1)
        low += [RESTITUTION_BOUNDS[0]] * len(self.pairs)
        high += [RESTITUTION_BOUNDS[1]] * len(self.pairs)
        return np.asarray(low), np.asarray(high)

    def owners(self) -> list[tuple[str, object]]:
        """What each vector entry belongs to: ("body", id) (position, velocity), ("friction", id),
        ("skid", id), ("mass", id) or ("pair", pair)."""
        owners: list[tuple[str, object]] = []
        for body, skid, (_, size) in zip(self.bodies, self._skids(), self._body_slots()):
            owners += [("body", body)] * (size - skid - 1) + [("friction", body)] + [("skid", body)] * skid
        owners += [("mass", body) for body in self.bodies[1:]]
        owners += [("pair", pair) for pair in self.pairs]
        return owners

    def scale(self) -> np.ndarray:
        values: list[float] = []
        for moving, skid in zip(self.moving, self._skids()):
            values += [0.05, 0.05] + ([0.3, 0.3] if moving else []) + [0.5] + ([0.3] if skid else [])
        return np.asarray(values + [0.5] * (len(self.bodies) - 1) + [0.2] * len(self.pairs))

    def unpack(
        self, vector: np.ndarray, estimates: Mapping[int, BodyEstimate]
    ) -> tuple[dict[int, BodyEstimate], dict[tuple[int, int], float]]:
        reference = estimates[self.bodies[0]].mass
        updated: dict[int, BodyEstimate] = {}
        for body, moving, skid, (offset, size) in zip(self.bodies, self.moving, self._skids(), self._body_slots()):
            values = vector[offset : offset + size]
            updated[body] = replace(
                estimates[body],
                position=np.array(values[:2]),
                velocity=np.array(values[2:4]) if moving else np.zeros(2),
                friction=float(np.clip(math.exp(values[4 if moving else 2]), *MU_BOUNDS)),
            )
            if skid:
                updated[body] = replace(updated[body], skid_friction=float(np.clip(math.exp(values[-1]), *SKID_FRICTION_BOUNDS)))
        offset = sum(size for _, size in self._body_slots())
        for k, body in enumerate(self.bodies[1:]):
            updated[body] = replace(updated[body], mass=reference * math.exp(vector[offset + k]))
        offset += len(self.bodies) - 1
        pair_e = {p: float(vector[offset + k]) for k, p in enumerate(self.pairs)}
        return updated, pair_e


def _local_rmse(fits: Sequence[TrackFit]) -> float:
    """Pooled RMSE (m) of the local closed-form fits of these tracks' stretches (sample-weighted)."""
    pairs = [(s.rmse, s.samples) for fit in fits for s in fit.stretches]
    samples = sum(n for _, n in pairs)
    return math.sqrt(sum(r * r * n for r, n in pairs) / samples) if samples else 0.0


def _refine_component(
    packing: _Packing,
    estimates: Mapping[int, BodyEstimate],
    pair_e: Mapping[tuple[int, int], float],
    pair_frames: Mapping[tuple[int, int], int],
    horizons: Sequence[int],
    observations: Observations,
    config: FitConfig,
    deadline: float = math.inf,
    noise_floor: float = 0.0,
    contacts: Sequence[tuple[tuple[int, int], int]] = (),
    decided_pairs: Sequence[tuple[int, int]] = (),
) -> tuple[dict[int, BodyEstimate], dict[tuple[int, int], float], int, int]:
    """Cumulative-prefix least squares over one component.

    contacts: recorded (pair, frame) collisions the replay must make (one
    residual each, ``_contact_residuals``), in the stages whose frames hold
    them; decided_pairs: pairs whose every contact is in ``contacts`` (one
    residual each against the replay's unrecorded collisions of the pair).

    deadline: ``_budget_clock()`` value by which the component must be
    done. Prefix stages get PREFIX_BUDGET_SHARE of the time left (skipped
    once it is spent), the whole-video stage the rest; a stage that runs out
    keeps its best vector so far. Returns the updated estimates, pair
    restitutions, rollout count and the number of stages cut short or skipped.

    noise_floor: RMSE (m, over the stage's weighted samples) at which a stage
    stops: its start vector already there skips it in one rollout. A stage
    within ``config.stall_floor_multiple`` floors also stops after an
    iteration that lowers the cost by less than
    ``config.min_relative_improvement`` of it.

    A stage fitting frames < H frees only what those frames can inform:
    bodies seen before H; the masses and restitutions of collisions, and the
    friction of bodies moving, long enough before H to show the response
    (FitConfig.mass_after_seconds, restitution_after_seconds,
    friction_after_seconds). Everything else keeps its current value (a
    parameter without data would otherwise drift in the optimiser's null space).
    """
    tracks = [estimates[b].track for b in packing.bodies]
    low, high = packing.bounds()
    vector = np.clip(packing.pack(estimates, pair_e), low, high)
    scale = packing.scale()
    first_seen = {t.id: int(t.frames[t.observed][0]) for t in tracks}
    # From which frame a body's motion shows its friction: seen moving, or set moving by its first collision.
    first_motion = {
        body: first_seen[body] if moving else min((f for p, f in pair_frames.items() if body in p), default=math.inf)
        for body, moving in zip(packing.bodies, packing.moving)
    }
    restitution_after = frames_in(config.restitution_after_seconds, observations.fps)
    friction_after = frames_in(config.friction_after_seconds, observations.fps)
    mass_after = frames_in(config.mass_after_seconds, observations.fps)
    owners = packing.owners()
    evaluations = 0
    skipped = 0
    started = _budget_clock()
    prefix_deadline = started + PREFIX_BUDGET_SHARE * max(deadline - started, 0.0)

    for stage, horizon in enumerate(horizons):
        last_stage = stage == len(horizons) - 1
        stage_deadline = deadline if last_stage else prefix_deadline
        if _budget_clock() > stage_deadline:
            skipped += 1
            continue
        seen_pairs = {p for p, frame in pair_frames.items() if frame + restitution_after < horizon}
        free = np.array(
            [
                (kind == "body" and first_seen[owner] < horizon)
                or (kind == "friction" and first_motion[owner] + friction_after < horizon)
                or (kind == "mass" and any(owner in p for p, frame in pair_frames.items() if frame + mass_after < horizon))
                or (kind == "skid" and any(owner in p for p in seen_pairs))
                or (kind == "pair" and owner in seen_pairs)
                for kind, owner in owners
            ]
        )
        if not free.any():
            continue
        fixed = vector.copy()
        best: list = [math.inf, vector[free].copy()]  # cost, sub-vector: kept when the deadline interrupts
        # Sums of squared residuals at an RMSE: its square times the stage's total sample weight.
        weight = sum(float(t.weights[t.observed & (t.frames < horizon)].sum()) for t in tracks)
        floor_cost = noise_floor**2 * weight
        stall_cost = (config.stall_floor_multiple * noise_floor) ** 2 * weight

        def fn(sub: np.ndarray, horizon: int = horizon, fixed: np.ndarray = fixed, best: list = best,
               stage_deadline: float = stage_deadline, floor_cost: float = floor_cost) -> np.ndarray:
            nonlocal evaluations
            if _budget_clock() > stage_deadline:
                raise _BudgetExhausted
            evaluations += 1
            full = fixed.copy()
            full[free] = sub
            body_estimates, pairs = packing.unpack(full, estimates)
            world = _world([body_estimates[b] for b in packing.bodies], pairs, observations, config, with_camera=False)
            residuals = _residuals(world, tracks, horizon, config.simulator, contacts, decided_pairs)
            cost = float(residuals @ residuals)
            if cost < best[0]:
                best[0], best[1] = cost, sub.copy()
            if cost <= floor_cost:
                raise _AtNoiseFloor
            return residuals

        try:
            vector[free] = _least_squares_stage(fn, vector[free], low[free], high[free], scale[free], config, stall_cost)
        except _AtNoiseFloor:
            vector[free] = best[1]
        except _BudgetExhausted:
            vector[free] = best[1]
            skipped += 1
    updated, pairs = packing.unpack(vector, estimates)
    return updated, pairs, evaluations, skipped


# A stage that converged on a Broyden-updated Jacobian is restarted from
# there with a fresh forward difference, at most this many times: the
# convergence tests of a secant model can stop short of the minimum.
SECANT_RESTARTS = 3


def _least_squares_stage(
    fn: Callable[[np.ndarray], np.ndarray], x0: np.ndarray, low: np.ndarray, high: np.ndarray,
    scale: np.ndarray, config: FitConfig, stall_cost: float = 0.0,
) -> np.ndarray:
    """One stage's bounded least squares from x0 (n,); returns the solution (n,).

    Secant Jacobians (``config.secant_jacobian``) with restarts, or a forward
    difference every iteration; either way the stage ends early when
    iterations stop paying (``config.min_relative_improvement``) once the
    sum of squared residuals is at most ``stall_cost`` (a slow step further
    up is a plateau before a contact the replay has not found yet).
    """
    options = dict(bounds=(low, high), x_scale=scale, max_nfev=config.max_nfev_per_stage, method="trf",
                   ftol=config.tolerance, xtol=config.tolerance, gtol=config.tolerance)
    if not config.secant_jacobian:
        return least_squares(fn, x0, jac="2-point", callback=_stop_when_slow(config.min_relative_improvement, stall_cost), **options).x
    x = x0
    for _ in range(1 + SECANT_RESTARTS):
        secant = SecantJacobian(fn, high, config.min_relative_improvement)
        result = least_squares(secant.fun, x, jac=secant, callback=_stop_when_stalled(secant, stall_cost), **options)
        x = result.x
        if result.status in (-2, 0) or secant.fresh:  # -2: stalled (our callback), 0: max_nfev reached
            break
    return x


def _stop_when_stalled(secant: SecantJacobian, stall_cost: float) -> Callable[[object], None]:
    """least_squares callback: end the stage once a step from a fresh Jacobian stalled at a cost <= stall_cost."""

    def stop(intermediate_result) -> None:  # scipy passes the OptimizeResult by this name
        if secant.stalled and 2.0 * float(intermediate_result.cost) <= stall_cost:  # scipy's cost: half the sum
            raise StopIteration
        secant.stalled = False

    return stop


def _stop_when_slow(min_relative_improvement: float, stall_cost: float) -> Callable[[object], None]:
    """least_squares callback: end the stage after an iteration that lowered the cost by less than this share,
    at a cost <= stall_cost."""
    previous = [math.inf]

    def stop(intermediate_result) -> None:  # scipy passes the OptimizeResult by this name
        cost = 2.0 * float(intermediate_result.cost)  # scipy's cost is half the sum of squares
        if previous[0] - cost < min_relative_improvement * previous[0] and cost <= stall_cost:
            raise StopIteration
        previous[0] = cost

    return stop


def _budget_clock() -> float:
    """The clock of FitConfig.time_budget_seconds: this process's CPU seconds (all threads)."""
    return time.process_time()


PREFIX_BUDGET_SHARE = 0.6  # of a component's time budget for the prefix stages; the rest for the whole video


class _BudgetExhausted(Exception):
    """Raised inside the objective when FitConfig.time_budget_seconds has run out."""


class _AtNoiseFloor(Exception):
    """Raised inside the objective when a stage's RMSE has reached its noise floor."""


# --------------------------------------------------------------------------
# Stage 5: re-anchoring the continuation
# --------------------------------------------------------------------------
SPIN_MIN_SAMPLES = 3  # yaw samples of the last stretch needed to read a cube's spin
SPIN_QUADRATIC_SAMPLES = 6  # from this many on, the spin's (linear) decay is fitted too


def _observed_spin(track: ObjectTrack, breakpoints: Sequence[int], fps: float, frame: int) -> tuple[float, float] | None:
    """A cube's yaw (rad) and yaw rate (rad/s) at ``frame`` from the yaw its track shows over
    its last collision-free stretch (after the last breakpoint), or None when fewer than
    SPIN_MIN_SAMPLES yaw samples are known there.

    A square looks the same every quarter turn, so the yaw is unwrapped with period pi/2
    before a least-squares line (or, from SPIN_QUADRATIC_SAMPLES samples on, a parabola:
    the spin decays linearly while sliding, world/flows.py) is fitted in time.
    """
    low = breakpoints[-1] + 1 if breakpoints else -1
    known = track.observed & (track.frames > low) & (track.frames <= frame) & np.isfinite(track.yaw)
    if int(known.sum()) < SPIN_MIN_SAMPLES:
        return None
    times = track.frames[known] / fps
    yaw = np.unwrap(track.yaw[known], period=0.5 * np.pi)
    degree = 2 if times.size >= SPIN_QUADRATIC_SAMPLES else 1
    coefficients = np.polyfit(times - frame / fps, yaw, degree)
    return float(coefficients[-1]), float(coefficients[-2])


# Shapes whose yaw rate is read from the track's yaw: a cylinder's spin changes its friction at
# later contacts; oracle tracks carry its yaw, perception gives NaN (then nothing is read).
SPIN_SEEN_SHAPES = ("cube", "cylinder")
# m: a body whose last stretch has only 2 samples (a contact in the last frames) is anchored
# from them when the replay misses its last observed position by more than this.
SHORT_STRETCH_MISS = 0.05


def _seen_motion(fit: TrackFit, friction: float, replay_position: np.ndarray, fps: float, last: int,
                 gravity: float) -> tuple[tuple[np.ndarray, np.ndarray], tuple[int, ...]] | None:
    """Position (2,) m and velocity (2,) m/s at frame ``last`` from the track, and the breakpoints
    that bound the samples they came from; None: keep the replay's state.

    The last stretch's slide, unless its tail left that slide (a collision in the last frames
    that the change points cannot see yet, local_fit.late_departure): then a line through the
    tail. A last stretch of 2 samples is used only when the replay is clearly elsewhere.
    """
    stretch, track = fit.stretches[-1], fit.track
    known = track.observed & (track.frames >= round(stretch.start_time * fps)) & (track.frames <= last)
    frames, positions = track.frames[known], track.positions[known, :2]
    times, at = frames / fps, last / fps
    if stretch.samples >= 3:
        cut = late_departure(times, positions, stretch, gravity)
        if cut is None:
            return stretch.state_at(at, gravity), fit.breakpoints
        return tail_state(times[cut:], positions[cut:], friction, gravity, at), (*fit.breakpoints, int(frames[cut]) - 1)
    if stretch.samples == 2 and frames.size >= 2 and float(np.linalg.norm(positions[-1] - replay_position)) > SHORT_STRETCH_MISS:
        return tail_state(times[-2:], positions[-2:], friction, gravity, at), fit.breakpoints
    return None


def _anchor(world: World, track_fits: Mapping[int, TrackFit], observations: Observations, config: FitConfig) -> Anchor | None:
    """States at the last observed frame from each body's last collision-free stretch.

    A body is anchored when it is seen on the last frame and its track gives
    its motion there (``_seen_motion``: a last stretch of at least 3 samples,
    or its tail after a collision in the last frames; 2 samples only when the
    replay is clearly elsewhere; else the replay's state is kept). An anchored state that
    would overlap another body is dropped (the replay is kept) rather than
    inventing a push.
    """
    last = observations.num_frames - 1
    if last < 1:
        return None
    time_at = last / observations.fps
    replay = (config.simulator or simulate)(world, (), observations.num_frames)
    column = {b: k for k, b in enumerate(replay.body_ids)}
    states: dict[int, BodyState] = {}
    for body in world.bodies:
        fit = track_fits[body.id]
        seen_last = fit.track.observed[fit.track.frames == last]
        if not (seen_last.size and seen_last[0]):
            continue
        seen = _seen_motion(fit, body.friction, replay.positions[last, column[body.id], :2], observations.fps, last, config.gravity)
        if seen is None:
            continue
        (position, velocity), breakpoints = seen
        yaw, yaw_rate = float(replay.yaw[last, column[body.id]]), 0.0
        seen_spin = _observed_spin(fit.track, breakpoints, observations.fps, last) if body.shape.kind in SPIN_SEEN_SHAPES else None
        if seen_spin is not None:  # the track shows the body's orientation: it decides later contacts
            yaw, yaw_rate = seen_spin
        states[body.id] = BodyState(
            (float(position[0]), float(position[1]), body.shape.rest_height),
            (float(velocity[0]), float(velocity[1]), 0.0),
            yaw=yaw, yaw_rate=yaw_rate, time=time_at,
        )
    # Drop anchored states that overlap anything at the anchor time.
    where = {b.id: (states[b.id].position if b.id in states else replay.positions[last, column[b.id]], b) for b in world.bodies if replay.active[last, column[b.id]] or b.id in states}
    for body_id in list(states):
        position, body = where[body_id]
        for other_id, (other_position, other) in where.items():
            if other_id == body_id:
                continue
            gap, _, _ = footprint_distance(
                footprint_of(body), position[0], position[1], states[body_id].yaw,
                footprint_of(other), other_position[0], other_position[1], float(replay.yaw[last, column[other_id]]),
            )
            if gap < 0:
                states.pop(body_id)
                break
    if not states:
        return None
    return Anchor(time_at, tuple(sorted(states.items())))


# --------------------------------------------------------------------------
# The entry point
# --------------------------------------------------------------------------
def identify(observations: Observations, config: FitConfig = FitConfig()) -> tuple[World, FitReport]:
    """Fit an executable World to observed tracks.

    Returns the world (bodies carry fitted entry states, friction, masses and
    restitution; ``provenance`` holds the fit report) and the report. The
    stages (docs/identification.md) are the functions called below, in order.
    """
    # One BLAS thread: the optimiser's matrices are small, and threaded OpenBLAS on a
    # shared, loaded machine spent 255x longer per SVD than one thread (docs/benchmarks.md).
    with threadpool_limits(limits=1, user_api="blas"):
        return _identify(observations, config)


def _identify(observations: Observations, config: FitConfig) -> tuple[World, FitReport]:
    """identify's stages, in order (docs/identification.md)."""
    began, began_cpu = time.perf_counter(), _budget_clock()
    usable, flags = _observed_tracks(observations)
    candidates = _candidates(usable, observations, config)
    usable, started = _entering_at_unexplained_starts(usable, candidates, observations.fps, config, flags)
    if started:
        candidates = _candidates(usable, observations, config)
    track_fits = _local_fits(usable, candidates, observations.fps, config)
    late = _late_pairs(candidates, observations, config)
    log_ratios, pair_e = _response_estimates(candidates)
    pair_e = {pair: e for pair, e in pair_e.items() if pair not in late}  # too little of the response to read e
    components = connected_components([t.id for t in usable], [c.bodies for c in candidates])
    masses, mass_identified = _component_masses(usable, components, log_ratios, config)
    default_e = float(np.median(list(pair_e.values()))) if pair_e else config.restitution_prior
    estimates, defaulted = _initial_estimates(
        usable, track_fits, masses, mass_identified, default_e, bool(pair_e), candidates, flags, config
    )
    refinement = _Refinement(0, 0, 0)
    if config.joint:
        estimates, pair_e, refinement = _joint_refinement(
            components, candidates, estimates, pair_e, default_e, defaulted, observations, config, track_fits, late
        )
    if pair_e:
        # Bodies carry the typical restitution for collisions not seen yet; so do the late pairs.
        informed = [e for pair, e in pair_e.items() if pair not in late]
        typical_e = float(np.median(informed)) if informed else default_e
        pair_e = {pair: typical_e if pair in late else e for pair, e in pair_e.items()}
        estimates = {i: replace(e, restitution=typical_e) for i, e in estimates.items()}
    world = _world([estimates[t.id] for t in usable], pair_e, observations, config)
    object_reports, rmse = _object_reports(world, observations, estimates, defaulted, flags, config)
    if config.materials_from_masses:
        # After the reports: a link needs both bodies' fit RMSE; the scaling keeps every ratio, so the RMSEs hold.
        world, revisions = revise_materials(world, _mass_links(candidates, log_ratios, observations, config),
                                            config.density_prior, components, {o.id: o.rmse for o in object_reports})
        object_reports = _flag_revisions(revisions, object_reports)
    report = FitReport(
        objects=object_reports,
        collisions_used=tuple((c.bodies[0], c.bodies[1], c.frame) for c in candidates),
        components=tuple(components),
        stages=refinement.stages,
        function_evaluations=refinement.evaluations,
        seconds=time.perf_counter() - began,
        cpu_seconds=_budget_clock() - began_cpu,
        rmse=rmse,
        budget_exhausted=refinement.skipped_stages > 0,
        skipped_stages=refinement.skipped_stages,
    )
    anchor = _anchor(world, track_fits, observations, config) if usable else None
    provenance = {"fit": report.to_dict(), "source": dict(observations.source)}
    precise_ids = precise_tracks(observations)
    world = replace(world, provenance=provenance, anchor=anchor)
    replayed = replayed_collisions(world, config.simulator)
    world = replace(world, observed_collisions=recorded_collisions(candidates, observations, precise_ids, replayed))
    precise = sorted(precise_ids & {t.id for t in usable})
    decided = frozenset((a, b) for i, a in enumerate(precise) for b in precise[i + 1 :])
    return with_replayed_collisions(world, config.simulator, decided, observations, replayed=replayed), report


def recorded_collisions(candidates: Sequence[CandidateCollision], observations: Observations, precise: frozenset[int],
                        replayed: Sequence[tuple[int, int, int]]) -> tuple[tuple[int, int, int], ...]:
    """(a, b, frame), a < b, sorted by frame: what the track analysis records of the video's collisions.

    A candidate with one-sided evidence (CandidateCollision.corroborated false) counts only where the fitted
    replay (``replayed``: replayed_collisions) makes the pair collide within the contact-episode gap; then one
    collision per contact episode (segments.contact_episode_starts; precise: segments.precise_tracks). In that
    order: an unconfirmed candidate starting an episode would otherwise take the episode's corroborated
    collision out of the record with it (another body's impulse read on a pair that then collides).

    A collision of a pair not both precise takes the frame of the replay's nearest collision of the pair within
    the contact-episode gap, if it makes one: for noisy tracks the track analysis says which pairs collide and
    the fitted replay when (a change point read on a few noisy samples lands early where a track is lost before
    the contact; dev 24242, perceived tracks: the record's frames off MuJoCo's by 0.93 frames on average, 43 %
    early, the replay's by 0.64, 22 %). Two precise tracks keep their own frame (oracle tracks: 0.15 against 0.47).
    """
    confirmed = [c for c in candidates if c.corroborated or _near(c.event, replayed, observations.fps)]
    inside = [c for c in contact_episode_starts(confirmed, observations, precise) if 0 <= c.frame < observations.num_frames]
    timed = {c.event if set(c.bodies) <= precise else (_nearest(c.event, replayed, observations.fps) or c.event) for c in inside}
    return tuple(sorted(timed, key=lambda c: (c[2], c[0], c[1])))


def replayed_collisions(world: World, simulator: Callable[..., object] | None = None) -> list[tuple[int, int, int]]:
    """(a, b, frame), a < b, of the collisions the world's replay makes inside its observed frames."""
    replay = (simulator or simulate)(world, (), max(world.observed_frames, 1))
    return [(min(e.bodies), max(e.bodies), e.frame) for e in replay.events
            if e.kind == "collision" and e.frame < world.observed_frames]


def _nearest(event: tuple[int, int, int], events: Sequence[tuple[int, int, int]], fps: float) -> tuple[int, int, int] | None:
    """The event (a, b, frame) of ``events`` of the same pair closest in time to ``event`` within the
    contact-episode gap (the earlier on a tie), or None."""
    gap = frames_in(CONTACT_EPISODE_GAP_SECONDS, fps)
    same = [other for other in events if other[:2] == event[:2] and abs(other[2] - event[2]) <= gap]
    return min(same, key=lambda other: (abs(other[2] - event[2]), other[2])) if same else None


def _near(event: tuple[int, int, int], events: Sequence[tuple[int, int, int]], fps: float) -> bool:
    """An event (a, b, frame) of ``events`` has the same pair within the contact-episode gap of ``event``."""
    return _nearest(event, events, fps) is not None


def with_replayed_collisions(
    world: World, simulator: Callable[..., object] | None = None, decided_pairs: frozenset[tuple[int, int]] = frozenset(),
    observations: Observations | None = None, replayed: Sequence[tuple[int, int, int]] | None = None,
) -> World:
    """The world with its fitted replay's collisions in the video added to ``observed_collisions``.

    The track analysis (stage 1) misses a weak contact (a light touch of a
    heavy body); the fitted replay, which must explain every track, still
    makes that pair collide. A replayed collision of a pair with no recorded
    one within the contact-episode gap is added at the replay's frame, unless
    the pair is in ``decided_pairs`` (sorted ids): two precise tracks whose
    touches the track analysis saw by geometry (segments.precise_tracks), where
    a replayed collision the video does not show is the fit's error. With
    ``observations`` (the tracks the world was fitted to), a replayed collision
    is added only where the pair's tracks show the two touching
    (segments.seen_touching): a replayed contact of bodies the video shows
    apart, or does not show, is the fit's error too (a misplaced perceived
    track, a fragment track the fit moved onto a neighbour).

    One-sided collisions the replay does not make are already out of the
    record (``recorded_collisions``). ``replayed``: the world's ``replayed_collisions``, when already computed.
    """
    replayed = replayed_collisions(world, simulator) if replayed is None else replayed

    given = tuple(world.observed_collisions or ())
    tracks = {t.id: t for t in observations.objects} if observations is not None else None

    def shown(a: int, b: int, frame: int) -> bool:
        return tracks is None or (a in tracks and b in tracks and seen_touching(tracks[a], tracks[b], frame))

    added = tuple(c for c in replayed if (c[0], c[1]) not in decided_pairs and not _near(c, given, world.fps) and shown(*c))
    record = given + added
    return world if record == given else replace(world, observed_collisions=record)


def _observed_tracks(observations: Observations) -> tuple[list[ObjectTrack], dict[int, list[str]]]:
    """The tracks with at least one observed frame, and per object id its flags (never observed)."""
    usable = [t for t in observations.objects if t.observed.sum() > 0]
    flags: dict[int, list[str]] = {t.id: [] for t in observations.objects}
    for track in observations.objects:
        if track.observed.sum() == 0:
            flags[track.id].append("never observed: left out of the world")
    return usable, flags


def _candidates(usable: Sequence[ObjectTrack], observations: Observations, config: FitConfig) -> list[CandidateCollision]:
    """Stage 1: candidate collisions from the usable tracks."""
    return find_candidate_collisions(
        Observations(tuple(usable), observations.fps, observations.num_frames, observations.camera),
        config.gravity, config.friction_prior,
    )


def _entering_at_unexplained_starts(usable: Sequence[ObjectTrack], candidates: Sequence[CandidateCollision], fps: float,
                                    config: FitConfig, flags: dict[int, list[str]]) -> tuple[list[ObjectTrack], bool]:
    """The tracks, those of bodies seen at rest and then set moving by nothing the tracks show
    (segments.unexplained_start) starting there: their earlier samples weigh 0, so the body enters the world
    at that frame with the motion it was seen to have (the world moves bodies only by collisions; one slide
    through the rest and the motion is metres off both); and whether any did. Appends to ``flags``."""
    tracks, started = [], False
    for track in usable:
        start = unexplained_start(track, usable, candidates, fps, config.gravity, config.friction_prior)
        if start is not None:
            flags[track.id].append(f"seen at rest until frame {start}, then moving with no collision seen: enters the world there")
            track = replace(track, weights=np.where(track.frames < start, 0.0, track.weights))
            started = True
        tracks.append(track)
    return tracks, started


def _local_fits(usable: Sequence[ObjectTrack], candidates: Sequence[CandidateCollision], fps: float,
                config: FitConfig) -> dict[int, TrackFit]:
    """Stage 2: closed-form fits of every collision-free stretch, split at the candidates."""
    breakpoints: dict[int, list[int]] = {t.id: [] for t in usable}
    for c in candidates:
        for body in c.bodies:
            breakpoints[body].append(c.frame)
    return {t.id: _fit_stretches(t, breakpoints[t.id], fps, config) for t in usable}


def _component_masses(
    usable: Sequence[ObjectTrack], components: Sequence[tuple[int, ...]],
    log_ratios: Mapping, config: FitConfig,
) -> tuple[dict[int, float], set[int]]:
    """Stage 3: masses (kg) per contact-connected component, scaled by the semantic prior; the ids whose mass was identified."""
    priors = {t.id: prior_mass(t.shape, t.material, config.density_prior) for t in usable}
    masses: dict[int, float] = {}
    identified: set[int] = set()
    for component in components:
        component_masses, component_identified = _solve_masses(component, log_ratios, priors)
        masses.update(component_masses)
        identified |= component_identified
    return masses, identified


def _similar_friction(
    track: ObjectTrack, usable: Sequence[ObjectTrack], own: Mapping[int, float | None], weak: Mapping[int, float | None], prior: float,
) -> tuple[float, str]:
    """A body's friction when its own stretches did not identify one, and where it came from: the median
    identified friction of similar objects (same material and shape, then any); else the weak readings
    (``_friction_estimate(weak=True)``) of the body itself, then of similar objects; else the prior.
    The prior is a guess several times the frictions the stretches read (0.3 against 0.05-0.1 in the
    generator's scenes): a struck body that took it stopped in a third of the distance."""
    others = [o for o in usable if o.id != track.id]
    similar = [o for o in others if o.material == track.material and o.shape.kind == track.shape.kind]
    for readings, pool, source in (
        (own, similar, "median of similar objects"),
        (own, others, "median of other objects"),
        (weak, [track], "its own short stretches"),
        (weak, similar, "short stretches of similar objects"),
        (weak, others, "short stretches of other objects"),
    ):
        values = [readings[o.id] for o in pool if readings[o.id] is not None]
        if values:
            return float(np.median(values)), source
    return prior, "the prior"


# Samples a body's first stretch needs for its own velocity to start the joint fit: two samples show the
# direction a body comes from; a contact at the video's third frame leaves two, and the next stretch's velocity
# (after the hit) points the other way in a head-on one (97474 scene 80 from video: 2.8 m off).
MIN_VELOCITY_SAMPLES = 2


def _initial_estimates(
    usable: Sequence[ObjectTrack], track_fits: Mapping[int, TrackFit], masses: Mapping[int, float],
    mass_identified: set[int], default_e: float, restitution_observed: bool, candidates: Sequence,
    flags: dict[int, list[str]], config: FitConfig,
) -> tuple[dict[int, BodyEstimate], dict[int, dict[str, str]]]:
    """Per body: the entry state of its first stretch, friction (own, similar objects, prior), mass;
    and per body what was defaulted and why. Appends to ``flags``."""
    own_friction = {i: _friction_estimate(f) for i, f in track_fits.items()}
    weak_friction = {i: _friction_estimate(f, weak=True) for i, f in track_fits.items()}
    defaulted: dict[int, dict[str, str]] = {t.id: {} for t in usable}
    estimates: dict[int, BodyEstimate] = {}
    for track in usable:
        fit = track_fits[track.id]
        first = fit.stretches[0]
        rest_start = first.samples >= MIN_REST_SAMPLES and not np.any(first.velocity)
        if first.samples < MIN_VELOCITY_SAMPLES and len(fit.stretches) > 1:
            # A contact right after entering the view: the velocity before it
            # was never seen. Start from the next stretch's velocity and let
            # the joint fit find the one that explains the contact.
            first = replace(first, velocity=fit.stretches[1].velocity)
        friction = own_friction[track.id]
        if friction is None:
            friction, source = _similar_friction(track, usable, own_friction, weak_friction, config.friction_prior)
            defaulted[track.id]["friction"] = f"no observed deceleration: {source}"
        if track.id not in mass_identified:
            defaulted[track.id]["mass"] = "no informative collision: density prior x shape volume"
        if int(track.observed.sum()) < config.min_frames:
            flags[track.id].append(f"observed on only {int(track.observed.sum())} frames: zero velocity assumed")
            first = replace(first, velocity=np.zeros(2))
            defaulted[track.id]["velocity"] = "too few frames: at rest"
        yaw_known = track.yaw[track.observed]
        yaw_known = yaw_known[np.isfinite(yaw_known)]
        estimates[track.id] = BodyEstimate(
            track=track,
            start_time=first.start_time,
            position=first.position,
            velocity=first.velocity,
            yaw=float(yaw_known[0]) if yaw_known.size else 0.0,
            friction=float(np.clip(friction, *MU_BOUNDS)),
            mass=masses[track.id],
            restitution=default_e,
            rest_start=rest_start,
            skid_friction=config.skid_friction_prior if config.rolling_spheres and track.shape.kind == "sphere" else None,
        )
        if not restitution_observed and any(track.id in c.bodies for c in candidates):
            defaulted[track.id]["restitution"] = "no approaching collision observed: prior"
    return estimates, defaulted


@dataclass(frozen=True)
class _Refinement:
    """What the joint refinement cost: rollouts evaluated, prefix stages, stages cut short or skipped."""

    evaluations: int
    stages: int
    skipped_stages: int


def _first_collision_frames(candidates: Sequence[CandidateCollision]) -> dict[tuple[int, int], int]:
    """Per colliding pair (sorted ids), the frame of its first candidate collision."""
    first: dict[tuple[int, int], int] = {}
    for c in candidates:
        first[c.bodies] = min(first.get(c.bodies, c.frame), c.frame)
    return first


def _mass_links(candidates: Sequence[CandidateCollision], log_ratios: Sequence[tuple[int, int, float]],
                observations: Observations, config: FitConfig) -> list[tuple[int, int]]:
    """Pairs whose mass ratio the fit identified: with the joint fit, those whose first collision is at
    least FitConfig.mass_after_seconds before the video's end (the rule that frees their masses,
    _refine_component); without it, those with a local momentum estimate."""
    if not config.joint:
        return sorted({(a, b) for a, b, _ in log_ratios})
    return sorted(_pairs_with_response(candidates, observations, config.mass_after_seconds))


def _pairs_with_response(candidates: Sequence[CandidateCollision], observations: Observations, seconds: float) -> frozenset[tuple[int, int]]:
    """Pairs whose first candidate collision is at least ``seconds`` before the video's end: the video shows
    that much of their response."""
    after = frames_in(seconds, observations.fps)
    return frozenset(pair for pair, frame in _first_collision_frames(candidates).items() if frame + after < observations.num_frames)


def _flag_revisions(revisions: Sequence[MaterialRevision], reports: Sequence[ObjectFitReport]) -> tuple[ObjectFitReport, ...]:
    """The object reports with a flag on each body whose material belief the mass ratios moved (REPORT_CHANGE)."""
    moved = {r.body: r.message() for r in revisions if max(abs(r.after[m] - r.before[m]) for m in r.after) >= REPORT_CHANGE}
    return tuple(replace(o, flags=(*o.flags, moved[o.id])) if o.id in moved else o for o in reports)


def _late_pairs(candidates: Sequence[CandidateCollision], observations: Observations, config: FitConfig) -> frozenset[tuple[int, int]]:
    """Pairs whose first collision is less than FitConfig.restitution_after_seconds before the video's
    end: no stage of the joint fit frees their restitution (_refine_component), the video shows too
    little of the response to read it."""
    seen = _pairs_with_response(candidates, observations, config.restitution_after_seconds)
    return frozenset(_first_collision_frames(candidates)) - seen


def _joint_refinement(
    components: Sequence[tuple[int, ...]], candidates: Sequence, estimates: dict[int, BodyEstimate],
    pair_e: dict[tuple[int, int], float], default_e: float, defaulted: dict[int, dict[str, str]],
    observations: Observations, config: FitConfig, track_fits: Mapping[int, TrackFit],
    late: frozenset[tuple[int, int]] = frozenset(),
) -> tuple[dict[int, BodyEstimate], dict[tuple[int, int], float], _Refinement]:
    """Stage 4: cumulative-prefix least squares per component with collisions, within the time budget.
    Updates ``defaulted`` (mass and restitution of the bodies in replayed collisions are identified,
    but not the restitution of a body whose every pair is in ``late``, _late_pairs)."""
    estimates, pair_e = dict(estimates), dict(pair_e)
    evaluations = stages = skipped_stages = 0
    deadline = _budget_clock() + config.time_budget_seconds
    joint_components = [c for c in components if any(k.bodies[0] in c for k in candidates)]
    precise_ids = precise_tracks(observations)
    pair_frames = _first_collision_frames(candidates)
    for component in joint_components:
        pairs = tuple(sorted({c.bodies for c in candidates if c.bodies[0] in component}))
        for pair in pairs:
            pair_e.setdefault(pair, default_e)
        frames = sorted({c.frame for c in candidates if c.bodies[0] in component})
        horizons = sorted({min(f + config.prefix_margin_frames, observations.num_frames) for f in frames} | {observations.num_frames})
        colliding = {b for pair in pairs for b in pair}
        packing = _Packing(component, pairs, tuple(not estimates[b].rest_start for b in component),
                           tuple(estimates[b].skid_friction is not None and b in colliding for b in component))
        # Components left share the time left equally.
        left = len(joint_components) - joint_components.index(component)
        component_deadline = _budget_clock() + max(deadline - _budget_clock(), 0.0) / left
        floor = config.noise_floor_factor * _local_rmse([track_fits[b] for b in component])
        # Touches seen by geometry (two precise tracks) are facts the replay must reproduce.
        precise = sorted(precise_ids & set(component)) if config.reproduce_contacts else []
        decided = [(a, b) for i, a in enumerate(precise) for b in precise[i + 1 :]]
        contacts = [(c.bodies, c.frame) for c in candidates if c.bodies in decided]
        updated, fitted_e, used, skipped = _refine_component(
            packing, estimates, pair_e, pair_frames, horizons, observations, config, component_deadline, floor,
            contacts, decided,
        )
        estimates.update(updated)
        pair_e.update(fitted_e)
        responded = {b for pair in pairs if pair not in late for b in pair}
        for body in {b for pair in pairs for b in pair}:
            # The joint fit identified them from the collision it replays.
            defaulted[body].pop("mass", None)
            defaulted[body].pop("restitution", None)
            if body not in responded:
                defaulted[body]["restitution"] = "its collisions are in the video's last frames: typical restitution"
        evaluations += used
        stages += len(horizons)
        skipped_stages += skipped
    return estimates, pair_e, _Refinement(evaluations, stages, skipped_stages)


def _object_reports(
    world: World, observations: Observations, estimates: Mapping[int, BodyEstimate],
    defaulted: Mapping[int, Mapping[str, str]], flags: Mapping[int, list[str]], config: FitConfig,
) -> tuple[tuple[ObjectFitReport, ...], float]:
    """Per object: RMSE (m) of the fitted replay over its observed frames, what was identified or
    defaulted; and the RMSE over every observed sample (0 when nothing was observed)."""
    object_reports = []
    squared_errors = []
    if estimates:
        positions, _, order = _positions(world, max(observations.num_frames, 1), config.simulator)
        column = {b: k for k, b in enumerate(order)}
    for track in observations.objects:
        if track.id not in estimates:
            object_reports.append(ObjectFitReport(track.id, float("nan"), 0, (), {"all": "never observed"}, tuple(flags[track.id])))
            continue
        use = track.observed
        error = positions[track.frames[use], column[track.id]] - track.positions[use, :2]
        squared_errors.append(np.sum(error**2, axis=1))
        rmse = float(np.sqrt(np.mean(squared_errors[-1])))
        identified = tuple(
            name for name in ("position", "velocity", "friction", "mass", "restitution") if name not in defaulted[track.id]
        )
        object_reports.append(
            ObjectFitReport(track.id, rmse, int(use.sum()), identified, dict(defaulted[track.id]), tuple(flags[track.id]))
        )
    total = float(np.sqrt(np.mean(np.concatenate(squared_errors)))) if squared_errors else 0.0
    return tuple(object_reports), total
