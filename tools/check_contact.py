"""check_contact: do two objects touch in a rollout (optionally within an inclusive frame range)?

Collision events emitted by the engine are searched first; only when none
matches does a conservative footprint scan look for sustained contact (gap
within ``contact_tolerance``). The nearest distance is reported but distance
alone never establishes contact. For an edited rollout the first match is
compared with the base rollout under a frame tolerance (default 5 frames).
"""

from __future__ import annotations

from typing import Any, Mapping

from world.types import Rollout

from tools.common import DEFAULT_CONTACT_TOLERANCE, DEFAULT_FRAME_TOLERANCE, PairEvidence, pair_evidence, pair_query
from tools.registry import ToolSpec
from tools.session import BASE_ROLLOUT_ID, WorldSession
from tools.scene3d import check_contact3d

NAME = "check_contact"
STATUS = {"collision_event": "collision", "footprint_scan": "contact", "none": "no_contact"}


def _note(evidence: PairEvidence) -> str:
    if evidence.evidence == "collision_event":
        return "the rollout emitted collision events for this pair"
    if evidence.evidence == "footprint_scan":
        return "no collision event; footprints touch within the contact tolerance (sustained contact)"
    if evidence.frames_both_present == 0:
        return "the two objects are never present together in this range"
    return "no collision event and footprints never touch; distance alone does not establish contact"


def run(session: WorldSession, args: Mapping[str, Any]) -> dict[str, Any]:
    query = pair_query(session, args, NAME)
    a, b, rollout_id, rollout, start, end, evidence = (
        query.a, query.b, query.rollout_id, query.rollout, query.start, query.end, query.evidence
    )
    tolerance = float(args.get("contact_tolerance", DEFAULT_CONTACT_TOLERANCE))
    frame_tolerance = int(args.get("frame_tolerance", DEFAULT_FRAME_TOLERANCE))
    first = evidence.frames[0] if evidence.frames else None
    result: dict[str, Any] = {
        "rollout_id": rollout_id,
        "objects": [a, b],
        "range": {"frame_start": start, "frame_end": end},
        "status": STATUS[evidence.evidence],
        "contact": evidence.evidence != "none",
        "evidence": evidence.evidence,
        "matched_frames": list(evidence.touching_frames),
        "first_frame": first,
        "first_event": evidence.events[0] if evidence.events else None,
        "nearest_distance": evidence.nearest_distance,
        "nearest_frame": evidence.nearest_frame,
        "beyond_video": first is not None and first >= rollout.observed_frames,
        "observed_frames": int(rollout.observed_frames),
        "contact_tolerance": tolerance,
        "note": _note(evidence),
        "base_comparison": None,
    }
    if rollout_id != BASE_ROLLOUT_ID:
        result["base_comparison"] = _compare_with_base(session, a, b, start, end, tolerance, first, frame_tolerance)
    return result


def _compare_with_base(session: WorldSession, a: int, b: int, start: int, end: int, tolerance: float, first: int | None, frame_tolerance: int) -> dict[str, Any]:
    base: Rollout = session.base_rollout()
    base_end = min(end, base.horizon_frames - 1)
    base_evidence = pair_evidence(session.world, base, a, b, start, base_end, tolerance)
    base_first = base_evidence.frames[0] if base_evidence.frames else None
    if first is None and base_first is None:
        change, agrees, delta = "unchanged", True, None
    elif first is None:
        change, agrees, delta = "removed", False, None
    elif base_first is None:
        change, agrees, delta = "added", False, None
    else:
        delta = first - base_first
        agrees = abs(delta) <= frame_tolerance
        change = "unchanged" if agrees else "shifted"
    return {
        "base_status": STATUS[base_evidence.evidence],
        "base_first_frame": base_first,
        "frame_delta": delta,
        "frame_tolerance": frame_tolerance,
        "agrees_with_base": agrees,
        "change": change,
    }


TOOL = ToolSpec(
    name=NAME,
    order=2,
    description=(
        "Check whether object_a and object_b contact or collide in a rollout ('base' or an id from simulate_edit), "
        "optionally within an inclusive frame range. Searches collision events first, then a conservative footprint scan; "
        "distance alone does not establish contact. Returns status (collision | contact | no_contact), matched frames, "
        "nearest distance, whether the first match is beyond the observed video, and for edited rollouts a comparison "
        "with the base rollout under a 5-frame tolerance. On a 3D (Physion) world object_b may be a zone and the "
        "result adds the exact contact_time, the closest approach (nearest_distance, nearest_time) and the fitted "
        "latent properties the answer rests on."
    ),
    run=run,
    run3d=check_contact3d,
)
