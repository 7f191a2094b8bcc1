"""Tool routes: the listings (every major tool-calling API, one tool's schemas) and one POST route per tool."""

from __future__ import annotations

from typing import Callable, Literal

from fastapi import APIRouter, Query, Request
from fastapi.responses import Response

from server.contract import published_args_schema, response_schema
from server.errors import encoded_response, json_response, note
from server.openapi_docs import responses
from server.world_registry import pool_of
from tools.listings import LISTING_FORMATS, tool_listing
from tools.registry import get_tool, inline_tool_schema, tool_registry

router = APIRouter(tags=["tools"])


@router.get("/v1/tools", operation_id="list_tools", responses=responses(200, response_schema("tool_listing")))
def list_tools(format: Literal[LISTING_FORMATS] = Query("openai", description="the tool-calling API to list the tools for")) -> Response:  # noqa: A002
    return json_response({"format": format, "tools": tool_listing(format)})


@router.get("/v1/tools/{tool_name}", operation_id="describe_tool", responses=responses(200, response_schema("tool_description")))
def describe_tool(tool_name: str) -> Response:
    tool = get_tool(tool_name)
    return json_response({
        "name": tool.name, "description": tool.spec.description,
        "arguments_schema": tool.args_schema, "result_schema": inline_tool_schema(f"{tool.name}.result.json"),
    })


def _tool_endpoint(fixed_name: str | None) -> Callable:
    async def run_tool(request: Request, world_id: str, tool_name: str | None = None) -> Response:
        name = fixed_name or tool_name or ""
        note(request, world_id=world_id, tool=name)
        raw = await request.body()
        return encoded_response(await pool_of(request).call("run_tool", world_id, name, raw))

    return run_tool


for _tool in tool_registry().values():
    router.add_api_route(
        f"/v1/worlds/{{world_id}}/tools/{_tool.name}", _tool_endpoint(_tool.name), methods=["POST"],
        summary=_tool.name, description=_tool.spec.description, operation_id=_tool.name,
        responses=responses(200, inline_tool_schema(f"{_tool.name}.result.json")),
        # An empty body is {}: required only when the arguments have required properties.
        openapi_extra={"requestBody": {"required": bool(_tool.args_schema.get("required")), "content": {"application/json": {
            "schema": published_args_schema(inline_tool_schema(f"{_tool.name}.args.json"))}}}},
    )
# Any other name: 404 listing the tools (not in the OpenAPI spec: the routes above are the contract).
router.add_api_route("/v1/worlds/{world_id}/tools/{tool_name}", _tool_endpoint(None), methods=["POST"], include_in_schema=False)
