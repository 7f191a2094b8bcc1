"""Friction between bodies in the rollout: conservation, spin, rolling spheres, JSON.
(The law against MuJoCo: test_contact_friction_mujoco.py.)"""

from __future__ import annotations

import json

import numpy as np
import pytest

from tests.world.scenes import CUBE, SPHERE, body, world_of
from world.io import world_from_dict, world_to_dict
from world.rollout import simulate
from world.types import Body, BodyState, Shape

CYLINDER = Shape("cylinder", radius=0.2, half_height=0.2)


def _glancing(contact_friction, removal=1.0, shape=CYLINDER):
    striker = body(0, (-1.0, 0.0), (2.0, 0.0), shape=shape, mass=1.0, friction=0.05, contact_friction=contact_friction)
    target = body(1, (0.0, 0.25), shape=shape, mass=2.0, friction=0.05, contact_friction=contact_friction)
    return world_of(striker, target, fps=1000.0, observed_frames=1000, pair_restitution=((0, 1, 0.7),),
                    contact_slip_removal=removal)


def _just_after(rollout):
    hit = next(e for e in rollout.events if e.kind == "collision")
    return hit, int(np.ceil(hit.time * 1000.0)) + 1


def test_friction_conserves_momentum_loses_energy_and_spins_both_bodies():
    rollout = simulate(_glancing(0.3), horizon_frames=1000)
    hit, k = _just_after(rollout)
    masses = np.array([1.0, 2.0])
    # Momentum just after equals just before, up to the floor friction over that instant.
    before = masses @ rollout.velocities[k - 2, :, :2]
    after = masses @ rollout.velocities[k, :, :2]
    assert np.allclose(after, before, atol=0.05 * 9.81 * 0.002 * 3.0 + 1e-9)
    frictionless = simulate(_glancing(None), horizon_frames=1000)
    # The target leaves turned towards the striker's motion (+x), the striker less deflected.
    target_dir = np.arctan2(*rollout.velocities[k, 1, 1::-1])
    plain_dir = np.arctan2(*frictionless.velocities[k, 1, 1::-1])
    assert target_dir < plain_dir
    # Both cylinders spin (same sense: the tangential impulse acts on opposite sides).
    yaw_rate = (rollout.yaw[k + 1] - rollout.yaw[k]) * 1000.0
    assert np.all(np.abs(yaw_rate) > 0.1) and np.sign(yaw_rate[0]) == np.sign(yaw_rate[1])
    # Kinetic energy (translation + spin) does not grow.
    inertia = masses * CYLINDER.yaw_inertia_per_mass
    energy = 0.5 * (masses @ (rollout.velocities[k, :, :2] ** 2).sum(axis=1) + inertia @ yaw_rate**2)
    energy_plain = 0.5 * masses @ (frictionless.velocities[k, :, :2] ** 2).sum(axis=1)
    assert energy <= energy_plain + 1e-9


def test_no_slip_share_means_frictionless():
    with_zero = simulate(_glancing(0.3, removal=0.0), horizon_frames=1000)
    frictionless = simulate(_glancing(None), horizon_frames=1000)
    assert np.allclose(with_zero.positions, frictionless.positions, atol=1e-12)


def test_a_rolling_sphere_loses_forward_spin_to_friction_at_a_head_on_hit():
    """Vertical friction at the equator: a rolling sphere's forward spin drives its contact
    point down past the cube's face; friction brakes the spin, so it rolls on less far."""
    def world(contact_friction):
        sphere = Body(0, SPHERE, BodyState((0.0, 0.0, SPHERE.radius), (1.5, 0.0, 0.0)), mass=1.0, friction=0.4,
                      rolling_friction=0.03, restitution=0.5, contact_friction=contact_friction)
        cube = body(1, (1.0, 0.0), shape=CUBE, mass=5.0, friction=0.5, restitution=0.5, contact_friction=contact_friction)
        return world_of(sphere, cube, fps=100.0, observed_frames=400)
    with_friction = simulate(world(0.4), horizon_frames=400)
    without = simulate(world(None), horizon_frames=400)
    assert with_friction.positions[-1, 0, 0] < without.positions[-1, 0, 0] - 0.05


def test_friction_fields_round_trip_and_older_documents_stay_unchanged():
    world = _glancing(0.3, removal=0.45)
    document = json.loads(json.dumps(world_to_dict(world)))
    assert document["bodies"][0]["contact_friction"] == 0.3 and document["contact_slip_removal"] == 0.45
    assert world_from_dict(document) == world
    plain = world_to_dict(_glancing(None))
    assert "contact_friction" not in plain["bodies"][0] and "contact_slip_removal" not in plain
    assert world_to_dict(world_from_dict(plain)) == plain
    with pytest.raises(ValueError, match="contact_friction"):
        body(0, (0.0, 0.0), contact_friction=-0.1)
    with pytest.raises(ValueError, match="contact_slip_removal"):
        _glancing(0.3, removal=1.5)
