"""compare_rollouts: collision pairs of two rollouts, pairs added/removed, per-object trajectory differences."""

from __future__ import annotations

from typing import Any, Mapping

import numpy as np

from world.types import Rollout

from tools.common import column, r
from tools.errors import ToolError
from tools.registry import ToolSpec
from tools.session import BASE_ROLLOUT_ID, WorldSession

NAME = "compare_rollouts"


def collision_pairs(rollout: Rollout) -> dict[tuple[int, int], list[int]]:
    pairs: dict[tuple[int, int], list[int]] = {}
    for event in rollout.events:
        if event.kind == "collision" and len(event.bodies) == 2:
            pair = tuple(sorted(int(b) for b in event.bodies))
            pairs.setdefault(pair, []).append(int(event.frame))  # type: ignore[arg-type]
    return pairs


def _pair_list(pairs: dict[tuple[int, int], list[int]], keep: set[tuple[int, int]]) -> list[dict[str, Any]]:
    return [{"objects": list(p), "frames": pairs[p], "first_frame": pairs[p][0]} for p in sorted(keep)]


def _difference(reference: Rollout, edited: Rollout, object_id: int) -> dict[str, Any]:
    ref_col, edit_col = column(reference, object_id), column(edited, object_id)
    shared = min(reference.horizon_frames, edited.horizon_frames)
    in_ref = ref_col is not None and bool(reference.active[:shared, ref_col].any())
    in_edit = edit_col is not None and bool(edited.active[:shared, edit_col].any())
    entry: dict[str, Any] = {
        "object_id": object_id, "present_in_reference": in_ref, "present_in_edited": in_edit,
        "samples": 0, "mean_displacement": None, "max_displacement": None, "max_displacement_frame": None,
        "final_displacement": None,
    }
    if not (in_ref and in_edit):
        return entry
    both = reference.active[:shared, ref_col] & edited.active[:shared, edit_col]
    frames = np.flatnonzero(both)
    if frames.size == 0:
        return entry
    gaps = np.linalg.norm(reference.positions[frames, ref_col] - edited.positions[frames, edit_col], axis=-1)
    k = int(np.argmax(gaps))
    entry.update(
        samples=int(frames.size), mean_displacement=r(gaps.mean()), max_displacement=r(gaps[k]),
        max_displacement_frame=int(frames[k]), final_displacement=r(gaps[-1]),
    )
    return entry


def run(session: WorldSession, args: Mapping[str, Any]) -> dict[str, Any]:
    reference_id = args.get("reference_rollout_id", BASE_ROLLOUT_ID)
    edited_id = args.get("edited_rollout_id")
    if edited_id is None:
        edited_id = session.latest_edited_rollout_id()
        if edited_id is None:
            raise ToolError(
                code="rollout_not_found", tool=NAME, pointer="/edited_rollout_id", status=404,
                message="no edited rollout exists for this world yet; create one with simulate_edit or name edited_rollout_id",
                expected="an id returned by simulate_edit", valid_ids=session.rollout_ids(),
            )
    reference = session.rollout(reference_id, tool=NAME, pointer="/reference_rollout_id")
    edited = session.rollout(edited_id, tool=NAME, pointer="/edited_rollout_id")
    object_ids = args.get("object_ids")
    if object_ids is None:
        object_ids = list(session.world.body_ids)
    else:
        object_ids = [session.check_object(o, tool=NAME, pointer=f"/object_ids/{i}") for i, o in enumerate(object_ids)]
    selected = set(object_ids)
    ref_pairs, edit_pairs = collision_pairs(reference), collision_pairs(edited)
    if args.get("object_ids") is not None:
        ref_pairs = {p: f for p, f in ref_pairs.items() if selected & set(p)}
        edit_pairs = {p: f for p, f in edit_pairs.items() if selected & set(p)}
    ref_keys, edit_keys = set(ref_pairs), set(edit_pairs)
    return {
        "reference_rollout_id": reference_id,
        "edited_rollout_id": edited_id,
        "shared_frames": int(min(reference.horizon_frames, edited.horizon_frames)),
        "reference_collisions": _pair_list(ref_pairs, ref_keys),
        "edited_collisions": _pair_list(edit_pairs, edit_keys),
        "added_pairs": [list(p) for p in sorted(edit_keys - ref_keys)],
        "removed_pairs": [list(p) for p in sorted(ref_keys - edit_keys)],
        "common_pairs": [list(p) for p in sorted(ref_keys & edit_keys)],
        "trajectory_differences": [_difference(reference, edited, o) for o in object_ids],
    }


TOOL = ToolSpec(
    name=NAME,
    order=4,
    description=(
        "Compare a reference rollout (default 'base') with an edited rollout (default: the most recent one created by "
        "simulate_edit). Optional object_ids restricts the comparison. Returns the collision pairs of each rollout, the "
        "pairs added and removed by the edit, and per-object trajectory differences over shared frames "
        "(sample count, mean and max position change in metres)."
    ),
    run=run,
)
