"""Rolling spheres in the engine: the skid's exact end, a collision restarting the skid,
and the new world fields through JSON and edits. (The law itself is checked against
MuJoCo in test_rolling_mujoco.py.)"""

from __future__ import annotations

import json

import numpy as np
import pytest

from tests.world.scenes import CUBE, SPHERE, body, world_of
from world.edits import remove_object
from world.flows import SKID, SLIDE, SOLID_SPHERE_SLIP_FACTOR, start_sphere_segment
from world.io import world_from_dict, world_to_dict
from world.rollout import simulate
from world.types import Body, BodyState, STANDARD_GRAVITY as G

MU_SKID, MU_ROLL = 0.4, 0.03


def _sphere(body_id, xy, velocity, spin_velocity=None, **params):
    state = BodyState((xy[0], xy[1], SPHERE.radius), (*velocity, 0.0), spin_velocity=spin_velocity)
    params.setdefault("friction", MU_SKID)
    params.setdefault("rolling_friction", MU_ROLL)
    return Body(body_id, SPHERE, state, **params)


@pytest.mark.parametrize("speed", [0.5, 2.0])
def test_a_sphere_without_spin_skids_to_five_sevenths_then_rolls(speed):
    world = world_of(_sphere(0, (0.0, 0.0), (speed, 0.0), spin_velocity=(0.0, 0.0)), fps=1000.0, observed_frames=6000)
    rollout = simulate(world, horizon_frames=6000)
    t_skid = speed / (SOLID_SPHERE_SLIP_FACTOR * MU_SKID * G)
    v = rollout.velocities[:, 0, 0]
    t = rollout.times
    skid, rolling = t <= t_skid, (t > t_skid) & (v > 0)
    assert np.allclose(v[skid], speed - MU_SKID * G * t[skid], atol=1e-12)
    assert np.allclose(v[rolling], 5.0 / 7.0 * speed - MU_ROLL * G * (t[rolling] - t_skid), atol=1e-12)
    stop = next(e for e in rollout.events if e.kind == "stop")
    assert stop.time == pytest.approx(t_skid + 5.0 / 7.0 * speed / (MU_ROLL * G), abs=1e-12)


def test_a_rolling_sphere_does_not_skid():
    segment = start_sphere_segment(0.0, (0.0, 0.0, 0.2), (1.0, 0.5, 0.0), (1.0, 0.5), 0.0, 0.2, MU_SKID, MU_ROLL, G)
    assert segment.mode == SLIDE
    assert np.hypot(*segment.acceleration[:2]) == pytest.approx(MU_ROLL * G)


def test_a_sideways_spin_curves_the_skid_and_ends_rolling():
    """Slip (1, -1): the friction acts against it, the velocity turns; rolling at v - 2/7 slip."""
    segment = start_sphere_segment(0.0, (0.0, 0.0, 0.2), (1.0, 0.0, 0.0), (0.0, 1.0), 0.0, 0.2, MU_SKID, MU_ROLL, G)
    assert segment.mode == SKID
    _, velocity, _, _ = segment.state_at(segment.end)
    assert velocity[:2] == pytest.approx((1.0 - 2.0 / 7.0, 2.0 / 7.0), abs=1e-12)
    assert segment.spin_velocity_at(segment.end) == pytest.approx(velocity[:2], abs=1e-12)


def test_a_collision_changes_the_velocity_not_the_spin():
    """A rolling sphere hits a heavy resting cube head-on: right after the impulse it still spins
    forward, so it skids, and rolls on at v_pre + 5/7 (v_post - v_pre)."""
    sphere = _sphere(0, (0.0, 0.0), (1.0, 0.0), mass=1.0)
    cube = body(1, (1.0, 0.0), shape=CUBE, mass=50.0, friction=0.5, restitution=0.5)
    world = world_of(sphere, cube, fps=1000.0, observed_frames=3000, pair_restitution=((0, 1, 0.5),))
    rollout = simulate(world, horizon_frames=3000)
    hit = next(e for e in rollout.events if e.kind == "collision")
    v_pre = 1.0 - MU_ROLL * G * hit.time
    v_post = v_pre - hit.impulse / sphere.mass
    assert v_post < 0  # bounced back, still spinning forward
    t_skid_end = hit.time + (v_pre - v_post) / (SOLID_SPHERE_SLIP_FACTOR * MU_SKID * G)
    v_roll = v_pre + 5.0 / 7.0 * (v_post - v_pre)
    later = np.flatnonzero(rollout.times > t_skid_end + 0.01)[0]
    expected = v_roll + MU_ROLL * G * (rollout.times[later] - t_skid_end)  # rolling backwards, slowing
    assert rollout.velocities[later, 0, 0] == pytest.approx(expected, abs=1e-9)
    assert abs(v_roll) < 0.5 * abs(v_post)  # the forward spin eats most of the bounce


def test_rolling_fields_and_observed_collisions_round_trip_and_older_documents_stay_unchanged():
    world = world_of(_sphere(0, (0.0, 0.0), (1.0, 0.0), spin_velocity=(0.2, 0.0)), body(1, (2.0, 0.0)),
                     observed_collisions=((0, 1, 30),))
    document = json.loads(json.dumps(world_to_dict(world)))
    assert document["bodies"][0]["rolling_friction"] == MU_ROLL
    assert document["bodies"][0]["initial"]["spin_velocity"] == [0.2, 0.0]
    assert document["observed_collisions"] == [{"bodies": [0, 1], "frame": 30}]
    assert world_from_dict(document) == world
    plain = world_to_dict(world_of(body(0, (0.0, 0.0)), body(1, (2.0, 0.0))))
    assert "observed_collisions" not in plain and "rolling_friction" not in plain["bodies"][0]
    assert "spin_velocity" not in plain["bodies"][0]["initial"]
    assert world_to_dict(world_from_dict(plain)) == plain


def test_invalid_rolling_fields_are_named():
    with pytest.raises(ValueError, match="rolling_friction applies to spheres only"):
        body(0, (0.0, 0.0), shape=CUBE, rolling_friction=0.1)
    with pytest.raises(ValueError, match="observed_collisions"):
        world_of(body(0, (0.0, 0.0)), body(1, (2.0, 0.0)), observed_collisions=((0, 7, 3),))


def test_removing_an_object_drops_its_observed_collisions():
    world = world_of(body(0, (0.0, 0.0)), body(1, (2.0, 0.0)), body(2, (4.0, 0.0)),
                     observed_collisions=((0, 1, 10), (1, 2, 20)))
    assert remove_object(world, 0).observed_collisions == ((1, 2, 20),)
