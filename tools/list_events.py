"""list_events: all in/out/collision/stop events of a rollout, optionally filtered."""

from __future__ import annotations

from typing import Any, Mapping

from tools.common import boundaries, event_record, frame_range
from tools.registry import ToolSpec
from tools.session import BASE_ROLLOUT_ID, WorldSession
from tools.scene3d import list_events3d

NAME = "list_events"


def run(session: WorldSession, args: Mapping[str, Any]) -> dict[str, Any]:
    rollout_id = args.get("rollout_id", BASE_ROLLOUT_ID)
    rollout = session.rollout(rollout_id, tool=NAME)
    start, end = frame_range(args, rollout, NAME)
    object_id = args.get("object_id")
    if object_id is not None:
        object_id = session.check_object(object_id, tool=NAME, pointer="/object_id")
    kinds = set(args.get("kinds") or ("collision", "in", "out", "stop"))
    events = [
        event_record(e, rollout.observed_frames)
        for e in rollout.events
        if e.kind in kinds and start <= e.frame <= end and (object_id is None or object_id in e.bodies)
    ]
    return {
        "rollout_id": rollout_id,
        "range": {"frame_start": start, "frame_end": end},
        "count": len(events),
        "events": events,
        "boundaries": boundaries(rollout),
    }


TOOL = ToolSpec(
    name=NAME,
    order=8,
    description=(
        "List the events of a rollout in time order: collisions (pairs), in / out (an object enters / leaves "
        "the camera view) and stop (an object comes to rest), each with frame, time and whether it is beyond the "
        "observed video. Optional filters: kinds, object_id, inclusive frame range."
    ),
    run=run,
    run3d=list_events3d,
)
