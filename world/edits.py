"""Interventions on a world. Every function is pure: it returns a new World and
never mutates its input (World and Body are frozen).

Removal semantics: ``remove_object(world, body, from_frame=f)`` keeps the body
in the world for frames < f and removes it from frame f on (its
``active_until`` becomes ``f / fps``). The default ``f`` is the body's first
active frame ``round(initial.time * fps)``; removing a body at or before its
first active frame drops it from the world entirely, so the replay is the
world without it (the CLEVRER counterfactual "remove from the start").
"""

from __future__ import annotations

import dataclasses
import math
from typing import Sequence

from world.timebase import frame_of
from world.types import Body, Edit, World, EDIT_KINDS


def _body_index(world: World, body_id: object, field: str = "edit.body") -> int:
    for index, body in enumerate(world.bodies):
        if body.id == body_id and not isinstance(body_id, bool):
            return index
    raise ValueError(f"{field}: unknown body id {body_id!r}; known ids {list(world.body_ids)}")


def _replace_body(world: World, index: int, body: Body) -> World:
    bodies = world.bodies[:index] + (body,) + world.bodies[index + 1:]
    return dataclasses.replace(world, bodies=bodies)


def _scalar(value: object, field: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ValueError(f"{field}: expected a finite number, got {value!r}")
    return float(value)


def clone(world: World, new_id: str | None = None) -> World:
    """A copy of ``world`` (optionally with a new id); bodies are shared (they are immutable)."""
    return dataclasses.replace(world, id=world.id if new_id is None else new_id,
                               provenance=dict(world.provenance))


def first_active_frame(world: World, body_id: int) -> int:
    """Frame index at which the body enters the world: ``round(initial.time * fps)``."""
    return frame_of(world.bodies[_body_index(world, body_id)].initial.time, world.fps)


def remove_object(world: World, body_id: int, from_frame: int | None = None) -> World:
    """Remove a body from frame ``from_frame`` on (default: its first active frame = from the start)."""
    index = _body_index(world, body_id)
    body = world.bodies[index]
    first = frame_of(body.initial.time, world.fps)
    if from_frame is None:
        from_frame = first
    if isinstance(from_frame, bool) or not isinstance(from_frame, int) or from_frame < 0:
        raise ValueError(f"edit.from_frame: expected an integer frame >= 0, got {from_frame!r}")
    if from_frame <= first:
        bodies = world.bodies[:index] + world.bodies[index + 1:]
        pairs = tuple(p for p in world.pair_restitution if body_id not in (p[0], p[1]))
        anchor = world.anchor
        if anchor is not None:
            anchor = dataclasses.replace(anchor, states=tuple(s for s in anchor.states if s[0] != body_id))
        observed = None if world.observed_collisions is None else tuple(
            c for c in world.observed_collisions if body_id not in (c[0], c[1]))
        return dataclasses.replace(world, bodies=bodies, pair_restitution=pairs, anchor=anchor,
                                   observed_collisions=observed)
    until = from_frame / world.fps
    if body.active_until is not None and body.active_until <= until:
        return clone(world)  # already gone by then
    return _replace_body(world, index, dataclasses.replace(body, active_until=until))


def set_velocity(world: World, body_id: int, velocity: Sequence[float]) -> World:
    """Set the body's velocity (m/s) at its entry; 2 components mean (vx, vy) with vz = 0."""
    index = _body_index(world, body_id)
    try:
        values = [float(v) for v in velocity]
    except TypeError:
        raise ValueError(f"edit.value: set_velocity needs 2 or 3 numbers, got {velocity!r}") from None
    if len(values) == 2:
        values.append(0.0)
    if len(values) != 3 or not all(math.isfinite(v) for v in values):
        raise ValueError(f"edit.value: set_velocity needs 2 or 3 finite numbers, got {velocity!r}")
    body = world.bodies[index]
    initial = dataclasses.replace(body.initial, velocity=tuple(values))
    return _replace_body(world, index, dataclasses.replace(body, initial=initial))


def set_mass(world: World, body_id: int, mass: float) -> World:
    """Set the body's mass (kg, > 0)."""
    index = _body_index(world, body_id)
    mass = _scalar(mass, "edit.value")
    if mass <= 0:
        raise ValueError(f"edit.value: mass must be > 0, got {mass!r}")
    return _replace_body(world, index, dataclasses.replace(world.bodies[index], mass=mass))


def set_friction(world: World, body_id: int, friction: float) -> World:
    """Set the body's Coulomb friction coefficient with the plane (> 0)."""
    index = _body_index(world, body_id)
    friction = _scalar(friction, "edit.value")
    if friction <= 0:
        raise ValueError(f"edit.value: friction (mu) must be > 0, got {friction!r}")
    return _replace_body(world, index, dataclasses.replace(world.bodies[index], friction=friction))


def set_restitution(world: World, body_id: int, restitution: float, other: int | None = None) -> World:
    """Set the body's restitution in [0, 1], or only the pair's with ``other``."""
    index = _body_index(world, body_id)
    e = _scalar(restitution, "edit.value")
    if not 0.0 <= e <= 1.0:
        raise ValueError(f"edit.value: restitution must be in [0, 1], got {e!r}")
    if other is None:
        return _replace_body(world, index, dataclasses.replace(world.bodies[index], restitution=e))
    _body_index(world, other, field="edit.other")
    if other == body_id:
        raise ValueError(f"edit.other: must differ from edit.body ({body_id})")
    pairs = tuple(p for p in world.pair_restitution if {p[0], p[1]} != {body_id, other})
    return dataclasses.replace(world, pair_restitution=pairs + ((body_id, other, e),))


def apply_edit(world: World, edit: Edit) -> World:
    """Apply one Edit record (see world.types.Edit)."""
    if not isinstance(edit, Edit):
        raise ValueError(f"edit: expected a world.types.Edit, got {type(edit).__name__}")
    if edit.kind not in EDIT_KINDS:
        raise ValueError(f"edit.kind: expected one of {EDIT_KINDS}, got {edit.kind!r}")
    if edit.kind == "remove_object":
        return remove_object(world, edit.body, edit.from_frame)
    if edit.value is None:
        raise ValueError(f"edit.value: required for {edit.kind}")
    if edit.kind == "set_velocity":
        return set_velocity(world, edit.body, edit.value)  # type: ignore[arg-type]
    if edit.kind == "set_mass":
        return set_mass(world, edit.body, edit.value)  # type: ignore[arg-type]
    if edit.kind == "set_friction":
        return set_friction(world, edit.body, edit.value)  # type: ignore[arg-type]
    return set_restitution(world, edit.body, edit.value, edit.other)  # type: ignore[arg-type]


def apply_edits(world: World, edits: Sequence[Edit]) -> World:
    """Apply edits in order; returns a new World, the input is untouched.

    Errors name the failing edit, e.g. ``edits[1].body: unknown body id 9``.
    """
    result = clone(world)
    for position, edit in enumerate(edits):
        try:
            result = apply_edit(result, edit)
        except ValueError as error:
            message = str(error)
            raise ValueError(message.replace("edit.", f"edits[{position}].", 1) if message.startswith("edit")
                             else f"edits[{position}]: {message}") from None
    return result
