"""inspect_world_state: active objects and events at one frame; ``missing_frame`` instead of interpolating."""

from __future__ import annotations

from typing import Any, Mapping

from tools.common import boundaries, event_record, object_attributes, object_record, r
from tools.registry import ToolSpec
from tools.session import BASE_ROLLOUT_ID, WorldSession

NAME = "inspect_world_state"


def run(session: WorldSession, args: Mapping[str, Any]) -> dict[str, Any]:
    frame = int(args["frame"])
    rollout_id = args.get("rollout_id", BASE_ROLLOUT_ID)
    rollout = session.rollout(rollout_id, tool=NAME)
    observed = rollout.observed_frames
    result: dict[str, Any] = {
        "rollout_id": rollout_id,
        "frame": frame,
        "beyond_video": frame >= observed,
        "boundaries": boundaries(rollout),
    }
    if frame >= rollout.horizon_frames:
        result.update(
            status="missing_frame", time=None, objects=[], collisions=[], events=[],
            note=f"the rollout holds frames 0..{rollout.horizon_frames - 1}; states are not interpolated or extrapolated",
        )
        return result
    objects = [
        {**object_record(rollout, col, frame, body_id), **object_attributes(session.world, body_id)}
        for col, body_id in enumerate(rollout.body_ids)
        if rollout.active[frame, col]
    ]
    at_frame = [e for e in rollout.events if e.frame == frame]
    result.update(
        status="ok",
        time=r(rollout.times[frame]),
        objects=objects,
        collisions=[event_record(e, observed) for e in at_frame if e.kind == "collision"],
        events=[event_record(e, observed) for e in at_frame if e.kind != "collision"],
        note=None,
    )
    return result


TOOL = ToolSpec(
    name=NAME,
    order=5,
    description=(
        "Inspect a rollout ('base' or an id from simulate_edit) at one required frame: the active objects "
        "(position, velocity, yaw, visibility, attributes) and the collision and in/out events at that frame. "
        "A frame outside the rollout returns status missing_frame rather than an interpolated state."
    ),
    run=run,
)
