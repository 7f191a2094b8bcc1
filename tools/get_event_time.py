"""get_event_time: all contact/collision frames of two objects in a rollout, count, first frame, first event."""

from __future__ import annotations

from typing import Any, Mapping

from tools.common import pair_query
from tools.registry import ToolSpec
from tools.session import WorldSession

NAME = "get_event_time"


def run(session: WorldSession, args: Mapping[str, Any]) -> dict[str, Any]:
    query = pair_query(session, args, NAME)
    evidence = query.evidence
    first_event = evidence.events[0] if evidence.events else None
    return {
        "rollout_id": query.rollout_id,
        "objects": [query.a, query.b],
        "range": {"frame_start": query.start, "frame_end": query.end},
        "evidence": evidence.evidence,
        "count": len(evidence.frames),
        "frames": list(evidence.frames),
        "first_frame": evidence.frames[0] if evidence.frames else None,
        "first_time": first_event["time"] if first_event else None,
        "first_event": first_event,
        "events": list(evidence.events),
        "observed_frames": int(query.rollout.observed_frames),
    }


TOOL = ToolSpec(
    name=NAME,
    order=3,
    description=(
        "Get the frames at which object_a and object_b collide or touch in a rollout, optionally within an inclusive "
        "frame range: all matched frames, count, first frame and time, and the first event record (for temporal ordering). "
        "Uses collision events, or a conservative footprint scan when no collision record matches."
    ),
    run=run,
)
