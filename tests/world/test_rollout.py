"""Event-driven rollouts: collision response, contact times, degenerate contacts, bad input."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from tests.world.scenes import CUBE, CYLINDER, SPHERE, body, world_of
from world.rollout import default_horizon, simulate
from world.types import Body, BodyState, Edit, Shape, World

G = 9.81
TINY_MU = 1e-9  # friction small enough that momentum over one frame is conserved to ~1e-10


def collision_velocities(world: World, fps: float = 1000.0):
    """Velocities (N, 3) one frame before and one frame after the first collision, and the event."""
    world = dataclasses.replace(world, fps=fps)
    rollout = simulate(world, horizon_frames=int(2 * fps))
    event = next(e for e in rollout.events if e.kind == "collision")
    before = int(math.floor(event.time * fps))
    return rollout.velocities[before], rollout.velocities[before + 1], event, rollout


@pytest.mark.parametrize("m1, m2, v1, v2, e", [
    (1.0, 1.0, 2.0, 0.0, 1.0), (1.0, 3.0, 1.5, -0.5, 0.5), (2.0, 0.5, 1.0, 0.0, 0.0), (1.0, 1.0, 3.0, -3.0, 0.8),
])
def test_head_on_conserves_momentum_and_obeys_restitution(m1, m2, v1, v2, e):
    world = world_of(body(0, (-0.6, 0.0), (v1, 0.0), mass=m1, friction=TINY_MU, restitution=e),
                     body(1, (0.6, 0.0), (v2, 0.0), mass=m2, friction=TINY_MU, restitution=e))
    before, after, event, _ = collision_velocities(world)
    p_before = m1 * before[0] + m2 * before[1]
    p_after = m1 * after[0] + m2 * after[1]
    assert p_after == pytest.approx(p_before, abs=1e-6)
    relative_before = before[0, 0] - before[1, 0]
    relative_after = after[0, 0] - after[1, 0]
    assert relative_after == pytest.approx(-e * relative_before, abs=1e-6)
    ke_before = 0.5 * (m1 * before[0] @ before[0] + m2 * before[1] @ before[1])
    ke_after = 0.5 * (m1 * after[0] @ after[0] + m2 * after[1] @ after[1])
    assert ke_after <= ke_before + 1e-9
    # Impulse magnitude: j = (1 + e) |v_rel.n| / (1/m1 + 1/m2).
    assert event.impulse == pytest.approx((1 + e) * relative_before / (1 / m1 + 1 / m2), rel=1e-6)


@pytest.mark.parametrize("offset", [0.1, 0.25, 0.39])
def test_oblique_collision_acts_along_the_normal_only(offset):
    e = 0.7
    world = world_of(body(0, (-1.0, offset), (2.0, 0.0), friction=TINY_MU, restitution=e),
                     body(1, (0.0, 0.0), friction=TINY_MU, restitution=e, mass=2.0))
    before, after, event, rollout = collision_velocities(world)
    t = event.time
    # Analytic contact: centres 0.4 apart, x(t) = -1 + 2t, y = offset.
    expected_t = (1.0 - math.sqrt(0.4 ** 2 - offset ** 2)) / 2.0
    assert t == pytest.approx(expected_t, abs=1e-9)
    normal = np.array([-1.0 + 2.0 * t, offset]) / 0.4
    tangent = np.array([-normal[1], normal[0]])
    assert after[0, :2] @ tangent == pytest.approx(before[0, :2] @ tangent, abs=1e-6)
    assert after[1, :2] @ tangent == pytest.approx(0.0, abs=1e-6)
    momentum_before = before[0, :2] + 2.0 * before[1, :2]
    momentum_after = after[0, :2] + 2.0 * after[1, :2]
    assert np.allclose(momentum_after, momentum_before, atol=1e-6)
    assert (after[0, :2] - after[1, :2]) @ normal == pytest.approx(-e * (before[0, :2] - before[1, :2]) @ normal, abs=1e-6)


@pytest.mark.parametrize("v1, v2, mu1, mu2, gap", [
    (2.0, 0.0, 0.3, 0.3, 0.5), (2.5, -1.5, 0.2, 0.4, 0.5), (3.0, 1.0, 0.1, 0.2, 0.4),
])
def test_contact_time_with_friction_matches_the_quadratic_formula(v1, v2, mu1, mu2, gap):
    # Both slide along x; the gap closes as gap - (v1 - v2) t + (mu1 - mu2) g t^2 / 2 (while both move).
    world = world_of(body(0, (0.0, 0.0), (v1, 0.0), friction=mu1),
                     body(1, (0.4 + gap, 0.0), (v2, 0.0), friction=mu2))
    rollout = simulate(world, horizon_frames=100)
    collision = next(e for e in rollout.events if e.kind == "collision")
    a1 = -mu1 * G
    a2 = (mu2 * G if v2 < 0 else -mu2 * G) if v2 != 0 else 0.0
    qa, qb, qc = 0.5 * (a1 - a2), v1 - v2, -gap
    if abs(qa) < 1e-15:
        expected = -qc / qb
    else:
        expected = (-qb + math.sqrt(qb * qb - 4 * qa * qc)) / (2 * qa)
    # The formula holds only while both still move (a valid test case).
    assert expected < v1 / (mu1 * G) and (v2 == 0 or expected < abs(v2) / (mu2 * G))
    assert collision.time == pytest.approx(expected, abs=1e-10)


def test_body_at_rest_starts_sliding_when_hit():
    world = world_of(body(0, (-1.0, 0.0), (3.0, 0.0)), body(1, (0.0, 0.0)))
    rollout = simulate(world, horizon_frames=60)
    assert [e.kind for e in rollout.events if e.bodies == (1,)] == ["stop"]
    assert rollout.positions[-1, 1, 0] > 0.1


def test_newton_cradle_chain_transfers_momentum_through_touching_bodies():
    world = world_of(body(0, (-1.0, 0.0), (2.0, 0.0), restitution=1.0, friction=TINY_MU),
                     body(1, (0.0, 0.0), restitution=1.0, friction=TINY_MU),
                     body(2, (0.4, 0.0), restitution=1.0, friction=TINY_MU), fps=100.0)
    rollout = simulate(world, horizon_frames=100)
    pairs = [e.bodies for e in rollout.events if e.kind == "collision"]
    assert pairs == [(0, 1), (1, 2)]
    assert rollout.velocities[-1, 2, 0] == pytest.approx(2.0, abs=1e-6)
    assert abs(rollout.velocities[-1, 0, 0]) < 1e-6 and abs(rollout.velocities[-1, 1, 0]) < 1e-6


@pytest.mark.parametrize("e", [0.0, 0.3])
def test_pushing_contact_settles_instead_of_looping(e):
    # The body ahead brakes harder: after the hit the rear one keeps pushing it. The chain of
    # ever smaller impulses is settled: both slide together, stop together, never overlap.
    world = world_of(body(0, (-1.0, 0.0), (4.0, 0.0), friction=0.1, mass=3.0, restitution=e),
                     body(1, (0.0, 0.0), friction=0.9, mass=1.0, restitution=e), fps=200.0)
    rollout = simulate(world, horizon_frames=400)
    assert rollout.notes == ()
    assert sum(ev.kind == "collision" for ev in rollout.events) < 40
    gaps = np.linalg.norm(rollout.positions[:, 0, :2] - rollout.positions[:, 1, :2], axis=1) - 0.4
    assert gaps.min() >= -1e-9
    stops = {ev.bodies[0]: ev.time for ev in rollout.events if ev.kind == "stop"}
    assert stops[0] == pytest.approx(stops[1], abs=1e-12)
    assert np.all(rollout.velocities[-1] == 0.0)


@pytest.mark.parametrize("offset", [0.4, 0.4 + 1e-12])
def test_tangential_touch_gives_no_collision(offset):
    world = world_of(body(0, (-1.0, offset), (2.0, 0.0)), body(1, (0.0, 0.0)))
    rollout = simulate(world, horizon_frames=60)
    assert not [e for e in rollout.events if e.kind == "collision"]


def test_resting_bodies_in_contact_make_no_events():
    world = world_of(body(0, (0.0, 0.0)), body(1, (0.4, 0.0)), body(2, (0.2, 0.2 * math.sqrt(3))),
                     body(3, (0.8, 0.0), shape=CUBE))
    rollout = simulate(world, horizon_frames=50)
    assert rollout.events == ()


def test_separating_touching_bodies_make_no_events():
    world = world_of(body(0, (0.0, 0.0), (-1.0, 0.0)), body(1, (0.4, 0.0), (1.0, 0.0)))
    rollout = simulate(world, horizon_frames=50)
    assert [e.kind for e in rollout.events] == ["stop", "stop"]


@pytest.mark.parametrize("shape_a, shape_b", [(CUBE, CUBE), (CYLINDER, CUBE), (CUBE, SPHERE)])
def test_face_on_cube_contact_time_is_exact(shape_a, shape_b):
    v, mu = 2.0, 0.3
    world = world_of(body(0, (0.0, 0.0), (v, 0.0), shape_a, friction=mu), body(1, (1.0, 0.0), shape=shape_b))
    rollout = simulate(world, horizon_frames=60)
    collision = next(e for e in rollout.events if e.kind == "collision")
    gap = 1.0 - 0.4  # half sizes are 0.2 for every test shape
    expected = (v - math.sqrt(v * v - 2 * mu * G * gap)) / (mu * G)
    assert collision.time == pytest.approx(expected, abs=1e-9)


def test_rotated_cube_is_hit_on_its_corner():
    # A cube turned 45 degrees reaches 0.2*sqrt(2) along x: contact when the circle meets that corner.
    world = world_of(body(0, (-1.0, 0.0), (2.0, 0.0), CYLINDER, friction=TINY_MU),
                     body(1, (0.0, 0.0), shape=CUBE, yaw=math.pi / 4))
    rollout = simulate(world, horizon_frames=60)
    collision = next(e for e in rollout.events if e.kind == "collision")
    assert collision.time == pytest.approx((1.0 - 0.2 - 0.2 * math.sqrt(2)) / 2.0, abs=1e-6)


def test_default_horizon_is_observed_plus_twenty_percent():
    world = world_of(body(0, (0, 0)), observed_frames=128)
    assert default_horizon(world) == math.ceil(128 * 1.2)
    assert simulate(world).horizon_frames == 154


def test_body_entering_later_is_inactive_before_its_entry():
    late = Body(1, CYLINDER, BodyState((1.0, 0.0, 0.1), (0.0, 0.0, 0.0), time=0.5))
    rollout = simulate(world_of(body(0, (0, 0)), late, fps=10.0), horizon_frames=20)
    assert not rollout.active[:5, 1].any() and rollout.active[5:, 1].all()
    assert any(e.kind == "in" and e.bodies == (1,) and e.frame == 5 for e in rollout.events)


# --------------------------------------------------------------------------- bad input

def _overlapping():
    return world_of(body(0, (0.0, 0.0)), body(1, (0.3, 0.0)))


@pytest.mark.parametrize("make, field", [
    (lambda: Body(0, CYLINDER, BodyState((0, 0, 0.1)), mass=-1.0), "mass"),
    (lambda: Body(0, CYLINDER, BodyState((0, 0, 0.1)), friction=0.0), "friction"),
    (lambda: Body(0, CYLINDER, BodyState((0, 0, 0.1)), friction=-0.2), "friction"),
    (lambda: Body(0, CYLINDER, BodyState((float("nan"), 0, 0.1))), "position"),
    (lambda: Body(0, CYLINDER, BodyState((0, 0, 0.1), (0, float("inf"), 0))), "velocity"),
    (lambda: Shape("cube", half_extent=-0.1), "half_extent"),
    (lambda: simulate(_overlapping()), "initial.position"),
    (lambda: simulate(world_of(body(0, (0, 0))), edits=[Edit("remove_object", 7)]), "edits[0].body"),
    (lambda: simulate(world_of(body(0, (0, 0))), edits=[Edit("set_mass", 0, value=-2.0)]), "edits[0].value"),
    (lambda: simulate(world_of(body(0, (0, 0))), edits=[Edit("set_friction", 0, value=0.0)]), "edits[0].value"),
    (lambda: simulate(world_of(body(0, (0, 0))), horizon_frames=0), "horizon_frames"),
    (lambda: simulate(world_of(body(0, (0, 0))), edits=["remove 0"]), "edits[0]"),
])
def test_bad_input_raises_a_value_error_naming_the_field(make, field):
    with pytest.raises(ValueError) as info:
        make()
    assert field in str(info.value)


def test_overlap_error_names_both_bodies():
    with pytest.raises(ValueError, match=r"body 1 overlaps body 0"):
        simulate(_overlapping())
