"""inspect_object_trajectory: one object's per-frame records in a rollout over an optional inclusive range."""

from __future__ import annotations

from typing import Any, Mapping

import numpy as np

from tools.common import boundaries, column, frame_range, object_attributes, object_record
from tools.registry import ToolSpec
from tools.session import BASE_ROLLOUT_ID, WorldSession

NAME = "inspect_object_trajectory"


def run(session: WorldSession, args: Mapping[str, Any]) -> dict[str, Any]:
    object_id = session.check_object(args["object_id"], tool=NAME, pointer="/object_id")
    rollout_id = args.get("rollout_id", BASE_ROLLOUT_ID)
    rollout = session.rollout(rollout_id, tool=NAME)
    start, end = frame_range(args, rollout, NAME)
    stride = int(args.get("stride", 1))
    col = column(rollout, object_id)
    records: list[dict[str, Any]] = []
    if col is not None and start <= end:
        frames = np.arange(start, end + 1)
        frames = frames[rollout.active[start:end + 1, col]][::stride]
        records = [object_record(rollout, col, int(f), object_id) for f in frames]
    return {
        "rollout_id": rollout_id,
        "object_id": object_id,
        **object_attributes(session.world, object_id),
        "range": {"frame_start": start, "frame_end": end},
        "stride": stride,
        "status": "ok" if records else "no_records",
        "count": len(records),
        "first": records[0] if records else None,
        "last": records[-1] if records else None,
        "records": records,
        "boundaries": boundaries(rollout),
    }


TOOL = ToolSpec(
    name=NAME,
    order=6,
    description=(
        "Get one object's per-frame records (position, velocity, speed, yaw, visibility) in a rollout "
        "('base' by default), optionally over an inclusive frame range and with a stride. Returns the records, "
        "their count, and the first and last records; frames where the object is absent are skipped."
    ),
    run=run,
)
