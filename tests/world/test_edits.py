"""Edits are pure, recorded in the rollout manifest, and do what they say."""

from __future__ import annotations

import copy

import numpy as np
import pytest

from tests.world.scenes import body, world_of
from world import edits as E
from world.rollout import simulate
from world.types import Body, BodyState, Edit
from tests.world.scenes import CYLINDER


def chain_world():
    return world_of(body(0, (-1.0, 0.0), (3.0, 0.0), friction=0.2), body(1, (0.0, 0.0), friction=0.2),
                    body(2, (0.8, 0.1), friction=0.2), fps=25.0, id="chain")


@pytest.mark.parametrize("edit", [
    Edit("remove_object", 1), Edit("remove_object", 1, from_frame=10), Edit("set_velocity", 0, value=(1.0, 0.5, 0.0)),
    Edit("set_mass", 1, value=5.0), Edit("set_friction", 0, value=0.6), Edit("set_restitution", 0, value=0.1),
    Edit("set_restitution", 0, value=0.2, other=1),
])
def test_edits_never_mutate_the_base_world(edit):
    base = chain_world()
    snapshot = copy.deepcopy(base)
    edited = E.apply_edits(base, [edit])
    assert base == snapshot
    assert edited != base
    rollout = simulate(base, [edit], horizon_frames=60, rollout_id="cf")
    assert rollout.edits == (edit,)
    assert rollout.id == "cf" and rollout.world_id == "chain"


def test_remove_from_start_drops_the_body_and_changes_the_outcome():
    base = simulate(chain_world(), horizon_frames=80)
    removed = simulate(chain_world(), [Edit("remove_object", 1)], horizon_frames=80)
    assert removed.body_ids == (0, 2)
    assert (1, 2) in [e.bodies for e in base.events if e.kind == "collision"]
    assert [e.bodies for e in removed.events if e.kind == "collision"] == [(0, 2)]


@pytest.mark.parametrize("from_frame", [3, 10, 40])
def test_remove_from_frame_keeps_the_body_before_that_frame(from_frame):
    base = simulate(chain_world(), horizon_frames=80)
    edited = simulate(chain_world(), [Edit("remove_object", 1, from_frame=from_frame)], horizon_frames=80)
    k = edited.body_ids.index(1)
    assert edited.active[:from_frame, k].all()
    assert not edited.active[from_frame:, k].any()
    # Identical history before the removal (same closed-form flows).
    assert np.array_equal(edited.positions[:from_frame], base.positions[:from_frame])


def test_remove_object_default_is_the_first_active_frame():
    late = Body(3, CYLINDER, BodyState((2.0, 2.0, 0.1), time=1.0))
    world = world_of(body(0, (0, 0)), late, fps=25.0)
    assert E.first_active_frame(world, 3) == 25
    assert E.remove_object(world, 3).body_ids == (0,)
    kept = E.remove_object(world, 3, from_frame=30)
    assert kept.body(3).active_until == pytest.approx(30 / 25.0)


def test_setters_change_exactly_their_field():
    base = chain_world()
    assert E.set_velocity(base, 1, (0.5, -0.5)).body(1).initial.velocity == (0.5, -0.5, 0.0)
    assert E.set_mass(base, 2, 3.5).body(2).mass == 3.5
    assert E.set_friction(base, 0, 0.7).body(0).friction == 0.7
    assert E.set_restitution(base, 0, 0.3).body(0).restitution == 0.3
    assert E.set_restitution(base, 0, 0.3, other=2).pair_restitution == ((0, 2, 0.3),)
    assert E.clone(base, "copy").id == "copy" and E.clone(base, "copy").bodies == base.bodies


def test_set_velocity_changes_the_rollout():
    still = simulate(chain_world(), [Edit("set_velocity", 0, value=(0.0, 0.0, 0.0))], horizon_frames=40)
    assert [e for e in still.events if e.kind == "collision"] == []


@pytest.mark.parametrize("edit, message", [
    (Edit("remove_object", 9), "edits[0].body: unknown body id 9"),
    (Edit("set_restitution", 0, value=0.5, other=9), "edits[0].other"),
    (Edit("set_restitution", 0, value=1.5), "edits[0].value"),
    (Edit("set_velocity", 0, value=(1.0,)), "edits[0].value"),
    (Edit("remove_object", 0, from_frame=-1), "edits[0].from_frame"),
    (Edit("set_mass", 0), "edits[0].value"),
])
def test_invalid_edits_name_the_field(edit, message):
    with pytest.raises(ValueError, match=message.replace("[", r"\[").replace("]", r"\]")):
        E.apply_edits(chain_world(), [edit])
