"""Laws that hold for every scene (hypothesis): no energy gain, bounded interpenetration, termination."""

from __future__ import annotations

import itertools
import math

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from world.contacts import MIN_CLEARANCE_STEP, footprint_distance
from world.rollout import MAX_EVENTS, footprint_of, simulate
from world.types import Body, BodyState, Shape, World

# Interpenetration bound (m) for every sampled frame. Contacts are exact roots
# (circles) or bisected to 1e-12 s (squares), pushing contacts are settled and
# impacts act at the contact point (a spinning corner is pushed back), so only rounding remains,
# and where a spinning pair's contact points separate at a touch, the search resumes when a corner
# could come back (contacts.clearance_step), at least MIN_CLEARANCE_STEP later: a corner can
# sweep in by at most its closing speed x MIN_CLEARANCE_STEP (< 1 um here; the former fixed
# 1e-4 s re-search let a hypothesis case in by 22 um).
PENETRATION_TOL = 1e-6
FPS = 200.0
HORIZON = 600  # 3 s

SPACING = 0.8  # grid cell size (m): with sizes <= 0.2 and jitter <= 0.1, no initial overlap


@st.composite
def scenes(draw, spin: bool):
    n = draw(st.integers(2, 6))
    cells = draw(st.lists(st.tuples(st.integers(0, 2), st.integers(0, 2)), min_size=n, max_size=n, unique=True))
    bodies = []
    for body_id, (cx, cy) in enumerate(cells):
        kind = draw(st.sampled_from(["sphere", "cylinder", "cube"]))
        size = draw(st.floats(0.08, 0.2))
        shape = (Shape("cube", half_extent=size) if kind == "cube"
                 else Shape(kind, radius=size, half_height=0.1 if kind == "cylinder" else 0.0))
        jitter = draw(st.tuples(st.floats(-0.1, 0.1), st.floats(-0.1, 0.1)))
        speed = draw(st.floats(0.0, 4.0))
        heading = draw(st.floats(0.0, 2 * math.pi))
        state = BodyState(
            (cx * SPACING + jitter[0], cy * SPACING + jitter[1], shape.rest_height),
            (speed * math.cos(heading), speed * math.sin(heading), 0.0),
            yaw=draw(st.floats(0.0, math.pi)),
            yaw_rate=draw(st.floats(-6.0, 6.0)) if spin else 0.0)
        bodies.append(Body(body_id, shape, state, mass=draw(st.floats(0.2, 5.0)),
                           friction=draw(st.floats(0.05, 1.0)), restitution=draw(st.floats(0.0, 1.0))))
    return World(tuple(bodies), fps=FPS, observed_frames=HORIZON)


def kinetic_energy(world: World, rollout) -> np.ndarray:
    """(T,) J: translational plus rotational about z (off-centre impacts trade one for the other)."""
    masses = np.array([b.mass for b in world.bodies])
    inertias = masses * np.array([b.shape.yaw_inertia_per_mass for b in world.bodies])
    return (0.5 * np.einsum("n,tni,tni->t", masses, rollout.velocities, rollout.velocities)
            + 0.5 * np.einsum("n,tn,tn->t", inertias, rollout.yaw_rates, rollout.yaw_rates))


# derandomize: CI runs every clean clone with no example database; a fixed example sequence keeps its verdict
# reproducible (a random run found the at-rest bound below too short, twenty-fifth round)
PROPERTY_SETTINGS = settings(max_examples=60, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow])


@PROPERTY_SETTINGS
@given(scenes(spin=True))
def test_kinetic_energy_never_increases(world):
    rollout = simulate(world, horizon_frames=HORIZON)
    energy = kinetic_energy(world, rollout)
    assert np.all(np.diff(energy) <= 1e-9 * (1.0 + energy[:-1]))


@PROPERTY_SETTINGS
@given(scenes(spin=True))
def test_bodies_never_interpenetrate_beyond_the_tolerance(world):
    rollout = simulate(world, horizon_frames=HORIZON)
    footprints = [footprint_of(b) for b in world.bodies]
    # (T, N) m/s: the fastest point of each footprint (centre speed + spin x bounding radius)
    point_speed = (np.linalg.norm(rollout.velocities[:, :, :2], axis=2)
                   + np.abs(rollout.yaw_rates) * np.array([f.bounding_radius for f in footprints]))
    for a, b in itertools.combinations(range(len(world.bodies)), 2):
        sweep = MIN_CLEARANCE_STEP * float(np.max(point_speed[:, a] + point_speed[:, b]))
        for t in range(HORIZON):
            gap, _, _ = footprint_distance(footprints[a], *rollout.positions[t, a, :2], rollout.yaw[t, a],
                                           footprints[b], *rollout.positions[t, b, :2], rollout.yaw[t, b])
            assert gap >= -(PENETRATION_TOL + sweep), (a, b, t, gap, sweep)


@PROPERTY_SETTINGS
@given(scenes(spin=True))
def test_rollouts_terminate_with_everything_at_rest(world):
    rollout = simulate(world, horizon_frames=HORIZON)
    assert rollout.notes == ()
    assert len(rollout.events) < MAX_EVENTS
    # Speeds are at most 4 m/s and mu >= 0.05, so a lone slide ends within 4 / (0.05 g) = 8.2 s; a spin feeds its
    # slide and a late collision starts a new one (a random case still slid at 0.15 m/s at 9 s): check the flows end
    # within 30 s.
    longer = simulate(world, horizon_frames=HORIZON * 10)
    assert np.all(np.linalg.norm(longer.velocities[-1], axis=1) == 0.0)
