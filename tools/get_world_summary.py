"""get_world_summary: the objects of a world (ids, attributes, parameters) and its registered rollouts."""

from __future__ import annotations

from typing import Any, Mapping

from world.io import attribute_belief_to_dict
from world.timebase import frame_of

from tools.common import fit_error, r, vec
from tools.registry import ToolSpec
from tools.session import WorldSession, default_horizon_frames
from tools.scene3d import get_world_summary3d

NAME = "get_world_summary"


def _size(body: Any) -> dict[str, float]:
    shape = body.shape
    if shape.kind == "cube":
        return {"half_extent": r(shape.half_extent)}
    if shape.kind == "cylinder":
        return {"radius": r(shape.radius), "half_height": r(shape.half_height)}
    return {"radius": r(shape.radius)}


def _belief(belief: Any) -> dict[str, Any]:
    """The body's attribute probabilities, rounded as every number of the result."""
    document = attribute_belief_to_dict(belief)
    return {name: ({value: r(p) for value, p in entry.items()} if isinstance(entry, dict) else entry) for name, entry in document.items()}


def run(session: WorldSession, args: Mapping[str, Any]) -> dict[str, Any]:
    world = session.world
    objects = [
        {
            "object_id": int(body.id),
            "shape": body.shape.kind,
            "color": body.color,
            "material": body.material,
            "size": _size(body),
            "mass": r(body.mass),
            "friction": r(body.friction),
            "restitution": r(body.restitution),
            "entry_frame": frame_of(body.initial.time, world.fps),
            "exit_frame": None if body.active_until is None else frame_of(body.active_until, world.fps),
            "initial_position": vec(body.initial.position),
            "initial_velocity": vec(body.initial.velocity),
            **({} if body.rolling_friction is None else {"rolling_friction": r(body.rolling_friction)}),
            **({} if body.contact_friction is None else {"contact_friction": r(body.contact_friction)}),
            **({} if body.attribute_belief is None else {"attribute_belief": _belief(body.attribute_belief)}),
        }
        for body in world.bodies
    ]
    return {
        "world_id": session.world_id,
        "name": world.id,
        "fps": float(world.fps),
        "observed_frames": int(world.observed_frames),
        "default_horizon_frames": default_horizon_frames(world),
        "gravity": float(world.gravity),
        "has_camera": world.camera is not None,
        "object_count": len(objects),
        "objects": objects,
        "rollout_ids": session.rollout_ids(),
        "fit_error": fit_error(world),
        # What identification saw in the video (None: the world was not fitted to one).
        "observed_collisions": None if world.observed_collisions is None else [
            {"objects": [int(a), int(b)], "frame": int(frame)} for a, b, frame in world.observed_collisions],
    }


TOOL = ToolSpec(
    name=NAME,
    order=9,
    description=(
        "Summarise the world: every object's id, shape, color, material, size and fitted parameters "
        "(mass, friction, restitution, contact_friction between bodies when fitted, entry frame, initial state; for a world perceived from video also "
        "attribute_belief, the probability of each colour, material and shape value), the video's fps and observed frames, "
        "the ids of the registered rollouts, and the collisions seen in the video (observed_collisions, "
        "null for a world not fitted to a video). Call it first to ground object descriptions to ids."
    ),
    run=run,
    run3d=get_world_summary3d,
)
