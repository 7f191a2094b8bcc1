"""JSON documents: schema-valid, lossless round trips, clear errors."""

from __future__ import annotations

import copy
import dataclasses
import json
import math

import numpy as np
import pytest

from tests.world.scenes import CUBE, SPHERE, body, world_of
from world.camera import look_at_camera
from world.io import (rollout_from_dict, rollout_to_dict, validate_rollout_dict, validate_world_dict,
                      world_from_dict, world_to_dict)
from world.rollout import simulate
from world.observations import ObjectTrack, Observations, default_shape
from world.types import AttributeBelief, Body, BodyState, Edit, Shape


def rich_world():
    camera = look_at_camera((0.0, -6.0, 4.0), (0.0, 0.0, 0.0))
    late = Body(4, Shape("cylinder", radius=0.25, half_height=0.3, mesh_path="meshes/cyl.obj"),
                BodyState((3.0, 0.0, 0.3), (-1.0, 0.0, 0.0), yaw=0.3, time=0.4), mass=2.5, friction=0.35,
                restitution=0.6, color="cyan", material="metal", active_until=4.0)
    return world_of(
        body(0, (-1.0, 0.1), (2.0, 0.0), color="red", material="rubber"),
        body(1, (0.0, 0.0), shape=CUBE, yaw=0.7, yaw_rate=1.0 / 3.0, mass=1.0 / 3.0),
        body(2, (0.9, -0.4), (0.1, 0.7), shape=SPHERE, friction=0.123456789012345),
        late, fps=25.0, observed_frames=100, pair_restitution=((0, 1, 0.55),), camera=camera,
        id="scene_00042", provenance={"fit": {"rmse": 0.0123, "iterations": 40}, "source": "synth"})


def test_world_round_trip_is_lossless_through_json():
    world = rich_world()
    document = world_to_dict(world)
    validate_world_dict(document)
    text = json.dumps(document)
    again = world_from_dict(json.loads(text))
    assert again == world
    assert world_to_dict(again) == document


def test_rollout_round_trip_is_lossless_through_json():
    edits = (Edit("set_mass", 1, value=2.0), Edit("set_velocity", 2, value=(0.1, 0.2, 0.0)),
             Edit("set_restitution", 0, value=0.4, other=2), Edit("remove_object", 4, from_frame=50))
    rollout = simulate(rich_world(), edits, horizon_frames=120, rollout_id="cf-1")
    assert any(e.kind == "collision" for e in rollout.events)
    document = rollout_to_dict(rollout)
    validate_rollout_dict(document)
    again = rollout_from_dict(json.loads(json.dumps(document)))
    for name in ("times", "positions", "velocities", "yaw", "active", "visible"):
        assert np.array_equal(getattr(again, name), getattr(rollout, name)), name
        assert getattr(again, name).dtype == getattr(rollout, name).dtype
    for name in ("id", "world_id", "edits", "fps", "observed_frames", "body_ids", "events", "notes"):
        assert getattr(again, name) == getattr(rollout, name), name
    assert rollout_to_dict(again) == document


@pytest.mark.parametrize("path, value, where", [
    (("bodies", 0, "mass"), -1.0, "bodies/0/mass"),
    (("bodies", 0, "friction"), 0.0, "bodies/0/friction"),
    (("bodies", 1, "shape", "kind"), "torus", "bodies/1/shape/kind"),
    (("bodies", 0, "initial", "position"), [0.0, 1.0], "bodies/0/initial/position"),
    (("fps",), "25", "fps"),
    (("bodies", 0, "color"), "pink", "bodies/0/color"),
    (("camera", "rotation"), [[1, 0, 0]], "camera/rotation"),
])
def test_invalid_world_documents_are_rejected_with_their_path(path, value, where):
    document = copy.deepcopy(world_to_dict(rich_world()))
    target = document
    for key in path[:-1]:
        target = target[key]
    target[path[-1]] = value
    with pytest.raises(ValueError, match=where):
        world_from_dict(document)


def test_nan_position_in_a_document_is_rejected():
    document = world_to_dict(rich_world())
    document["bodies"][0]["initial"]["position"][0] = math.nan
    with pytest.raises(ValueError, match="position"):
        world_from_dict(document)


def test_unknown_pair_id_in_a_document_is_rejected():
    document = world_to_dict(rich_world())
    document["pair_restitution"][0]["bodies"] = [0, 99]
    with pytest.raises(ValueError, match="pair_restitution"):
        world_from_dict(document)


@pytest.mark.parametrize("mutate, where", [
    (lambda d: d["events"].append({"kind": "explosion", "bodies": [0], "time": 0.0, "frame": 0,
                                    "position": [0, 0, 0], "impulse": 0.0}), "events"),
    (lambda d: d.__setitem__("positions", d["positions"][:-1]), "positions"),
    (lambda d: d.pop("visible"), "visible"),
])
def test_invalid_rollout_documents_are_rejected(mutate, where):
    document = rollout_to_dict(simulate(rich_world(), horizon_frames=30))
    mutate(document)
    with pytest.raises(ValueError, match=where):
        rollout_from_dict(document)


# --------------------------------------------------------------------------- attribute beliefs
BELIEF = AttributeBelief.from_mappings({"red": 0.7, "purple": 0.2, "brown": 0.1}, {"metal": 0.35, "rubber": 0.65},
                                       {"cube": 0.9, "cylinder": 0.1}, support_frames=97)


def test_attribute_belief_round_trips_in_world_and_observation_documents():
    world = rich_world()
    perceived = dataclasses.replace(world, bodies=(dataclasses.replace(world.bodies[0], attribute_belief=BELIEF), *world.bodies[1:]))
    document = world_to_dict(perceived)
    validate_world_dict(document)
    assert document["bodies"][0]["attribute_belief"]["color"] == {"red": 0.7, "purple": 0.2, "brown": 0.1}
    assert "attribute_belief" not in document["bodies"][1]  # absent for bodies without one: older readers see the old format
    again = world_from_dict(json.loads(json.dumps(document)))
    assert again == perceived and again.bodies[0].attribute_belief.distribution("shape") == {"cube": 0.9, "cylinder": 0.1}
    assert world_from_dict(world_to_dict(world)).bodies[0].attribute_belief is None
    track = ObjectTrack(3, default_shape("cube"), [0, 1], [[0, 0, 0.2], [0.1, 0, 0.2]], [0.0, 0.0], [True, True], [1.0, 1.0],
                        color="red", material="rubber", attribute_belief=BELIEF)
    observations = Observations(objects=(track,))
    assert Observations.from_dict(json.loads(json.dumps(observations.to_dict()))).objects[0].attribute_belief == BELIEF


@pytest.mark.parametrize("color, material, support, message", [
    ({"red": 0.7, "blue": 0.2}, {"metal": 1.0}, 1, "sum to 1"),
    ({"pink": 1.0}, {"metal": 1.0}, 1, "among"),
    ({"red": 1.2, "blue": -0.2}, {"metal": 1.0}, 1, r"in \[0, 1\]"),
    ({"red": 1.0}, {"metal": 1.0}, -1, "support_frames"),
])
def test_invalid_attribute_beliefs_are_rejected(color, material, support, message):
    with pytest.raises(ValueError, match=message):
        AttributeBelief.from_mappings(color, material, {"sphere": 1.0}, support_frames=support)


def test_an_invalid_belief_in_a_document_is_rejected_with_its_path():
    document = world_to_dict(rich_world())
    document["bodies"][1]["attribute_belief"] = {"color": {"red": 0.5}, "material": {"metal": 1.0}, "shape": {"cube": 1.0}}
    with pytest.raises(ValueError, match=r"bodies\[1\].*sum to 1"):
        world_from_dict(document)
    document["bodies"][1]["attribute_belief"] = {"color": {"teal": 1.0}, "material": {"metal": 1.0}, "shape": {"cube": 1.0}}
    with pytest.raises(ValueError, match="bodies/1/attribute_belief"):
        world_from_dict(document)
