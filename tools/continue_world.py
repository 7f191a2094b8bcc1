"""continue_world: the factual world (no edit) continued to a longer horizon.

The continuation of the unedited world starts from the state fitted at the end
of the observed video (the world's anchor, see world/rollout.py); an edited
replay (simulate_edit) restarts from the initial states instead. So "what
happens next" must come from here, never from a no-op edit. The rollout is
registered under a deterministic id (``continue-<horizon>``): asking twice
for the same horizon returns the same rollout.
"""

from __future__ import annotations

from typing import Any, Mapping

from world.types import Rollout

from tools.common import boundaries, event_record
from tools.registry import ToolSpec
from tools.session import WorldSession, continuation_id
from tools.scene3d import continue_world3d

NAME = "continue_world"


def _continuation(session: WorldSession, horizon_frames: int) -> Rollout:
    base = session.base_rollout()
    if horizon_frames == base.horizon_frames:
        return base
    rollout_id = continuation_id(horizon_frames)
    existing = session.store.get_rollout(session.world_id, rollout_id)
    if existing is not None:
        return existing
    session.check_horizon(horizon_frames, tool=NAME, pointer="/horizon_frames")
    return session.register_factual_rollout(horizon_frames, rollout_id)


def run(session: WorldSession, args: Mapping[str, Any]) -> dict[str, Any]:
    rollout = _continuation(session, int(args["horizon_frames"]))
    observed = rollout.observed_frames
    return {
        "rollout_id": rollout.id,
        "world_id": session.world_id,
        "anchored": session.world.anchor is not None,
        "boundaries": boundaries(rollout),
        "collisions": [event_record(e, observed) for e in rollout.events if e.kind == "collision"],
        "in_out_events": [event_record(e, observed) for e in rollout.events if e.kind in ("in", "out")],
    }


TOOL = ToolSpec(
    name=NAME,
    # Read-only for a caller: the continuation is a function of the world, cached under the fixed id
    # continue-<H>, so repeating a call returns the same rollout and changes nothing.
    read_only=True,
    order=9,
    description=(
        "Continue the factual world (no edit) to horizon_frames frames: what happens next. The continuation starts "
        "from the state fitted at the end of the observed video. Returns rollout_id (usable in check_contact, "
        "list_events, inspect_*), collisions and in/out events with frames, and the boundaries."
    ),
    run=run,
    run3d=continue_world3d,
)
