"""World routes: create (validated in full before anything is stored), list, read, delete."""

from __future__ import annotations

import json

from fastapi import APIRouter, Request
from fastapi.responses import Response

from server.contract import response_schema
from server.errors import encoded_response, json_response, note
from server.openapi_docs import responses
from server.world_registry import pool_of, registry_of, world_body_schema

router = APIRouter(tags=["worlds"])


@router.post("/v1/worlds", operation_id="create_world", status_code=201,
             responses=responses(201, response_schema("world_created"), "the world was created"),
             openapi_extra={"requestBody": {"required": True, "content": {"application/json": {"schema": world_body_schema()}}}})
async def create_world(request: Request) -> Response:
    encoded = await pool_of(request).call("create_world_from_bytes", await request.body())
    note(request, world_id=json.loads(encoded)["world_id"])
    return encoded_response(encoded, 201)


@router.get("/v1/worlds", operation_id="list_worlds", responses=responses(200, response_schema("world_list")))
def list_worlds(request: Request) -> Response:
    rows = registry_of(request).store.list_worlds()
    return json_response({"worlds": [
        {"world_id": r.world_id, "name": r.name, "created_at": r.created_at, "object_count": r.body_count, "rollout_count": r.rollout_count}
        for r in rows
    ]})


@router.get("/v1/worlds/{world_id}", operation_id="get_world", responses=responses(200, response_schema("world_detail")))
def get_world(request: Request, world_id: str) -> Response:
    registry = registry_of(request)
    row = registry.store.world_row(world_id)
    document = registry.store.world_document(world_id)
    if row is None or document is None:
        raise registry.unknown_world(world_id)
    return json_response({
        "world_id": world_id, "name": row.name, "created_at": row.created_at, "object_count": row.body_count,
        "rollout_ids": registry.store.rollout_ids(world_id), "world": document,
    })


@router.delete("/v1/worlds/{world_id}", operation_id="delete_world", responses=responses(200, response_schema("world_deleted")))
def delete_world(request: Request, world_id: str) -> Response:
    return json_response(registry_of(request).delete_world(world_id))
