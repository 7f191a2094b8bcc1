"""Rollout routes: the registry of a world's rollouts and one rollout's summary or full document."""

from __future__ import annotations

from typing import Literal

from fastapi import APIRouter, Query, Request
from fastapi.responses import Response

from server.contract import response_schema
from server.errors import encoded_response, json_response
from server.openapi_docs import responses
from server.world_registry import pool_of, registry_of

router = APIRouter(tags=["rollouts"])


@router.get("/v1/worlds/{world_id}/rollouts", operation_id="list_rollouts", responses=responses(200, response_schema("rollout_list")))
def list_rollouts(request: Request, world_id: str) -> Response:
    registry = registry_of(request)
    if not registry.store.has_world(world_id):
        raise registry.unknown_world(world_id)
    return json_response({"world_id": world_id, "rollouts": [
        {"rollout_id": r.rollout_id, "parent_id": r.parent_id, "created_at": r.created_at,
         "horizon_frames": r.horizon_frames, "edits": r.edits}
        for r in registry.store.list_rollouts(world_id)
    ]})


@router.get("/v1/worlds/{world_id}/rollouts/{rollout_id}", operation_id="get_rollout",
            responses=responses(200, response_schema("rollout_detail")))
async def get_rollout(request: Request, world_id: str, rollout_id: str,
                      detail: Literal["summary", "full"] = Query("summary", description="full adds the per-frame rollout document")) -> Response:
    return encoded_response(await pool_of(request).call("rollout_summary", world_id, rollout_id, detail))
