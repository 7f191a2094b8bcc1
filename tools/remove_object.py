"""remove_object: the paper's legacy flat form of simulate_edit(edit_type="remove_object")."""

from __future__ import annotations

from typing import Any, Mapping

from world.types import Edit

from tools.registry import ToolSpec
from tools.session import WorldSession
from tools.simulate_edit import create_edited_rollout

NAME = "remove_object"


def run(session: WorldSession, args: Mapping[str, Any]) -> dict[str, Any]:
    body = session.check_object(args["object_id"], tool=NAME, pointer="/object_id")
    start = args.get("start_frame")
    edit = Edit(kind="remove_object", body=body, from_frame=None if start is None else int(start))
    return create_edited_rollout(session, args, edit, NAME)


TOOL = ToolSpec(
    name=NAME,
    read_only=False,  # adds a rollout to the world's registry
    order=7,
    description=(
        "Legacy flat form of simulate_edit with edit_type remove_object: remove object_id (optionally from "
        "start_frame) from the base world and replay. Returns the same evidence as simulate_edit, including the new rollout_id."
    ),
    run=run,
)
