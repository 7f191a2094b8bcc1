"""simulate_edit: edit the world (remove an object, change a parameter) and replay it.

Returns the new rollout's id (use it in later calls), the edit manifest,
trajectories (summary, sampled or full), collisions, in/out events, the
world's fit error and the rollout boundaries.
"""

from __future__ import annotations

from typing import Any, Mapping

import numpy as np

from world.io import edit_to_tool_record
from world.types import Edit, Rollout

from tools.common import boundaries, column, event_record, fit_error, object_attributes, object_record, r
from tools.errors import ToolError, invalid_argument
from tools.registry import ToolSpec
from tools.session import BASE_ROLLOUT_ID, WorldSession

NAME = "simulate_edit"
DEFAULT_DETAIL = "sampled"
DEFAULT_SAMPLE_EVERY = 25


edit_to_dict = edit_to_tool_record  # the tool-format record has one owner: world.io


def build_edit(session: WorldSession, args: Mapping[str, Any], tool: str) -> Edit:
    """The engine Edit for validated ``args``; 422/404 ToolError for inconsistent values."""
    kind = args["edit_type"]
    body = session.check_object(args["object_id"], tool=tool, pointer="/object_id")
    value = args.get("value")
    other = args.get("other_object_id")
    start = args.get("start_frame")
    if kind == "remove_object":
        if value is not None:
            raise invalid_argument(tool, "/value", "remove_object takes no value", "no 'value' property")
    elif kind == "set_velocity":
        if not isinstance(value, list) or len(value) != 3:
            raise invalid_argument(tool, "/value", "set_velocity needs value = [vx, vy, vz] in m/s", "an array of 3 numbers")
        value = tuple(float(v) for v in value)
    else:
        if isinstance(value, list) or value is None:
            raise invalid_argument(tool, "/value", f"{kind} needs a scalar value", "a number")
        value = float(value)
        if kind in ("set_mass", "set_friction") and not value > 0:
            raise invalid_argument(tool, "/value", f"{kind} value must be > 0, got {value}", "a number > 0")
        if kind == "set_restitution" and not 0 <= value <= 1:
            raise invalid_argument(tool, "/value", f"restitution must be in [0, 1], got {value}", "a number in [0, 1]")
    if other is not None:
        if kind != "set_restitution":
            raise invalid_argument(tool, "/other_object_id", "other_object_id only applies to set_restitution", "no 'other_object_id' property")
        other = session.check_object(other, tool=tool, pointer="/other_object_id")
        if other == body:
            raise invalid_argument(tool, "/other_object_id", "other_object_id must differ from object_id", f"an object id other than {body}")
    return Edit(kind=kind, body=body, value=value, other=other, from_frame=None if start is None else int(start))


def _trajectory(session: WorldSession, rollout: Rollout, object_id: int, removed: set[int], detail: str, every: int) -> dict[str, Any]:
    entry: dict[str, Any] = {"object_id": object_id, **object_attributes(session.world, object_id), "removed": object_id in removed}
    col = column(rollout, object_id)
    frames = np.flatnonzero(rollout.active[:, col]) if col is not None else np.array([], dtype=int)
    if frames.size == 0:
        entry.update(active_frames=None, start=None, end=None, path_length=0.0, max_speed=0.0, moving_at_end=False)
        if detail != "summary":
            entry["samples"] = []
        return entry
    positions = rollout.positions[frames, col]
    speeds = np.linalg.norm(rollout.velocities[frames, col], axis=-1)
    start, end = object_record(rollout, col, int(frames[0]), object_id), object_record(rollout, col, int(frames[-1]), object_id)
    entry.update(
        active_frames={"first": int(frames[0]), "last": int(frames[-1])},
        start=start,
        end=end,
        path_length=r(np.linalg.norm(np.diff(positions, axis=0), axis=-1).sum()),
        max_speed=r(speeds.max()),
        moving_at_end=bool(end["moving"]),
    )
    if detail != "summary":
        chosen = frames if detail == "full" else frames[::every]
        if detail == "sampled" and chosen[-1] != frames[-1]:
            chosen = np.append(chosen, frames[-1])
        entry["samples"] = [object_record(rollout, col, int(f), object_id) for f in chosen]
    return entry


def rollout_evidence(session: WorldSession, rollout: Rollout, parent_id: str, new_edit: Edit, args: Mapping[str, Any]) -> dict[str, Any]:
    """The simulate_edit / remove_object answer for a freshly created rollout."""
    detail = args.get("trajectory_detail", DEFAULT_DETAIL)
    every = int(args.get("sample_every", DEFAULT_SAMPLE_EVERY))
    removed = {e.body for e in rollout.edits if e.kind == "remove_object"}
    observed = rollout.observed_frames
    return {
        "rollout_id": rollout.id,
        "world_id": session.world_id,
        "edit_manifest": {
            "based_on": parent_id,
            "applied": edit_to_dict(new_edit),
            "edits": [edit_to_dict(e) for e in rollout.edits],
        },
        "boundaries": boundaries(rollout),
        "fit_error": fit_error(session.world),
        "collisions": [event_record(e, observed) for e in rollout.events if e.kind == "collision"],
        "in_out_events": [event_record(e, observed) for e in rollout.events if e.kind in ("in", "out")],
        "trajectories": {
            "detail": detail,
            "sample_every": every if detail == "sampled" else None,
            "objects": [_trajectory(session, rollout, b, removed, detail, every) for b in session.world.body_ids],
        },
        "notes": [str(n) for n in getattr(rollout, "notes", ())],
    }


def create_edited_rollout(session: WorldSession, args: Mapping[str, Any], edit: Edit, tool: str) -> dict[str, Any]:
    parent_id = args.get("based_on", BASE_ROLLOUT_ID)
    parent = session.rollout(parent_id, tool=tool, pointer="/based_on")
    horizon = args.get("horizon_frames")
    if horizon is None:
        horizon = parent.horizon_frames
    session.check_horizon(int(horizon), tool=tool, pointer="/horizon_frames")
    edits = (*parent.edits, edit)
    try:
        rollout = session.create_rollout(edits, int(horizon), parent_id)
    except ValueError as error:
        # The engine refuses edits it cannot replay (e.g. a removal start frame it does not support).
        raise ToolError(code="invalid_edit", message=str(error)[:500], tool=tool, pointer="", expected="an edit the engine can replay", status=422) from None
    return rollout_evidence(session, rollout, parent_id, edit, args)


def run(session: WorldSession, args: Mapping[str, Any]) -> dict[str, Any]:
    return create_edited_rollout(session, args, build_edit(session, args, NAME), NAME)


TOOL = ToolSpec(
    name=NAME,
    read_only=False,  # adds a rollout to the world's registry
    order=1,
    description=(
        "Create a new rollout by editing the world and replaying its fitted dynamics. "
        "edit_type remove_object removes object_id (optionally from start_frame); set_velocity, set_mass, "
        "set_friction and set_restitution change a parameter. Edits stack on 'based_on' (default 'base'). "
        "Returns rollout_id (pass it to other tools), the edit manifest, collisions, in/out events, "
        "per-object trajectories (trajectory_detail: summary | sampled | full), fit error and boundaries."
    ),
    run=run,
)
