"""PhysMind over the Model Context Protocol (the official ``mcp`` SDK's low-level server).

Two transports serve the same ``Server``:

* Streamable HTTP at ``/mcp`` on the tool server's own app and port
  (stateless, JSON responses): ``mount_mcp(app, registry)``;
* stdio, the form desktop agent hosts launch: ``physmind mcp`` (server/mcp_cli.py).

Tools: ``list_worlds``, ``create_world`` (arguments as the body of ``POST
/v1/worlds``) and every tool of ``tools/`` with one more required argument,
``world_id``. Argument and result schemas are the HTTP API's
(``schemas/tools/``); results come back as structured content plus the same
JSON as text. A tool's own error (bad arguments, unknown world, rollout or
object) is a tool result with ``isError: true`` whose structured content is
the HTTP API's error object, so the model can read it and fix its call (MCP
2025-11-25: input validation errors are tool execution errors); an unknown
tool name is a JSON-RPC error (``-32602``). Worlds are resources
``physmind://worlds/{world_id}``.
"""

from __future__ import annotations

import json
from contextlib import asynccontextmanager
from typing import Any

import anyio.to_thread
import mcp_types as types
from mcp.server import Server
from mcp.server.transport_security import TransportSecuritySettings
from mcp.shared.exceptions import MCPError

from tools.errors import ToolError, invalid_argument
from tools.registry import inline_tool_schema, tool_registry, without_null_optionals

MCP_PATH = "/mcp"
SERVER_NAME = "physmind"
WORLD_URI_PREFIX = "physmind://worlds/"
WORLD_ID_PROPERTY = {"type": "string", "minLength": 1, "maxLength": 64,
                     "description": "the world to query: an id from list_worlds or create_world"}

LIST_WORLDS_SCHEMA = {"type": "object", "properties": {}, "additionalProperties": False}
CREATE_WORLD_SCHEMA = {
    "type": "object",
    "properties": {
        "world": {"type": "object", "description": "a fitted world document (schemas/world.schema.json; what `physmind build` writes)"},
        "name": {"type": "string", "minLength": 1, "maxLength": 200, "description": "a display name (default: the document's id)"},
        "horizon_frames": {"type": "integer", "minimum": 1,
                           "description": "frames of the base rollout (default: observed frames + 20 %)"},
    },
    "required": ["world"],
    "additionalProperties": False,
}
WORLD_TOOLS = ("list_worlds", "create_world")


def _annotations(read_only: bool, title: str) -> types.ToolAnnotations:
    # Nothing here deletes: a non-read-only tool adds a world or a rollout (a new id per call).
    return types.ToolAnnotations(title=title, read_only_hint=read_only, destructive_hint=False,
                                 idempotent_hint=read_only, open_world_hint=False)


def _with_world_id(schema: dict) -> dict:
    """A tool's argument schema with the required ``world_id`` in front."""
    public = {k: v for k, v in schema.items() if k not in ("$schema", "$id")}
    public["properties"] = {"world_id": WORLD_ID_PROPERTY, **schema.get("properties", {})}
    public["required"] = ["world_id", *schema.get("required", ())]
    return public


def mcp_tools() -> list[types.Tool]:
    """The MCP tool list: the two world tools, then every registered tool with ``world_id``."""
    listed = [
        types.Tool(name="list_worlds", description="List the worlds on this server (id, name, object and rollout counts).",
                   input_schema=LIST_WORLDS_SCHEMA, annotations=_annotations(True, "List worlds")),
        types.Tool(name="create_world",
                   description="Register a fitted world document; returns its world_id and the world summary. "
                               "Every other tool takes that world_id.",
                   input_schema=CREATE_WORLD_SCHEMA, annotations=_annotations(False, "Create a world")),
    ]
    for tool in tool_registry().values():
        listed.append(types.Tool(
            name=tool.name, description=tool.spec.description, input_schema=_with_world_id(tool.args_schema),
            output_schema=inline_tool_schema(f"{tool.name}.result.json"),
            annotations=_annotations(tool.spec.read_only, tool.name.replace("_", " ").capitalize())))
    return listed


def _error_text(error: dict) -> str:
    where = f" at {error['pointer']}" if error.get("pointer") else ""
    expected = f" (expected {error['expected']})" if error.get("expected") else ""
    valid = f"; valid ids: {error['valid_ids'][:20]}" if error.get("valid_ids") else ""
    return f"{error['code']}{where}: {error['message']}{expected}{valid}"


def _result(payload: dict) -> types.CallToolResult:
    text = json.dumps(payload, separators=(",", ":"), default=str)
    return types.CallToolResult(content=[types.TextContent(text=text)], structured_content=payload)


def _error_result(error: ToolError) -> types.CallToolResult:
    payload = error.to_dict()
    return types.CallToolResult(content=[types.TextContent(text=_error_text(payload["error"]))],
                                structured_content=payload, is_error=True)


def list_worlds_payload(store: Any) -> dict:
    """``{"worlds": [...]}`` as ``GET /v1/worlds`` answers it."""
    return {"worlds": [
        {"world_id": r.world_id, "name": r.name, "created_at": r.created_at, "object_count": r.body_count,
         "rollout_count": r.rollout_count}
        for r in store.list_worlds()]}


def world_payload(registry: Any, world_id: str) -> dict:
    """A stored world as ``GET /v1/worlds/{id}`` answers it. Raises ToolError for an unknown id."""
    store = registry.store
    row, document = store.world_row(world_id), store.world_document(world_id)
    if row is None or document is None:
        raise registry.unknown_world(world_id)
    return {"world_id": world_id, "name": row.name, "created_at": row.created_at, "object_count": row.body_count,
            "rollout_ids": store.rollout_ids(world_id), "world": document}


async def _call(registry: Any, pool: Any, name: str, arguments: dict) -> dict:
    """Run one MCP tool call: world creation and tools in the server's worker pool, as over HTTP. Raises ToolError."""
    if name == "list_worlds":
        return await anyio.to_thread.run_sync(list_worlds_payload, registry.store)
    if name == "create_world":
        body = without_null_optionals(arguments, CREATE_WORLD_SCHEMA)
        return json.loads(await pool.call("create_world_from_bytes", json.dumps(body).encode()))
    world_id = arguments.get("world_id")
    if not isinstance(world_id, str) or not world_id:
        raise invalid_argument(name, "/world_id", "missing or empty world_id" if world_id is None else
                               f"{world_id!r} is not a world id", "a world_id from list_worlds or create_world")
    rest = {k: v for k, v in arguments.items() if k != "world_id"}
    return json.loads(await pool.call("run_tool", world_id, name, json.dumps(rest).encode()))


def build_mcp_server(registry: Any, pool: Any, version: str) -> Server:
    """The low-level MCP server over a ``server.world_registry.WorldRegistry`` and its ``server.workers.WorkerPool``."""
    tools = mcp_tools()
    names = [tool.name for tool in tools]

    async def on_list_tools(ctx: Any, params: Any) -> types.ListToolsResult:
        return types.ListToolsResult(tools=tools)

    async def on_call_tool(ctx: Any, params: types.CallToolRequestParams) -> types.CallToolResult:
        if params.name not in names:
            raise MCPError(types.INVALID_PARAMS, f"unknown tool {params.name!r}; tools: {names}")
        try:
            payload = await _call(registry, pool, params.name, dict(params.arguments or {}))
        except ToolError as error:
            return _error_result(error)
        return _result(payload)

    async def on_list_resources(ctx: Any, params: Any) -> types.ListResourcesResult:
        rows = await anyio.to_thread.run_sync(registry.store.list_worlds)
        return types.ListResourcesResult(resources=[
            types.Resource(uri=WORLD_URI_PREFIX + r.world_id, name=r.world_id, title=r.name, mime_type="application/json",
                           description=f"world {r.name!r}: {r.body_count} objects, {r.rollout_count} rollouts")
            for r in rows])

    async def on_list_resource_templates(ctx: Any, params: Any) -> types.ListResourceTemplatesResult:
        return types.ListResourceTemplatesResult(resource_templates=[types.ResourceTemplate(
            uri_template=WORLD_URI_PREFIX + "{world_id}", name="world", mime_type="application/json",
            description="a stored world: its document and rollout ids")])

    async def on_read_resource(ctx: Any, params: types.ReadResourceRequestParams) -> types.ReadResourceResult:
        uri = str(params.uri)
        if not uri.startswith(WORLD_URI_PREFIX):
            raise MCPError(types.INVALID_PARAMS, f"unknown resource {uri!r}; expected {WORLD_URI_PREFIX}{{world_id}}")
        try:
            payload = await anyio.to_thread.run_sync(world_payload, registry, uri[len(WORLD_URI_PREFIX):])
        except ToolError as error:
            raise MCPError(types.INVALID_PARAMS, _error_text(error.to_dict()["error"])) from None
        return types.ReadResourceResult(contents=[types.TextResourceContents(
            uri=uri, mime_type="application/json", text=json.dumps(payload, separators=(",", ":")))])

    return Server(SERVER_NAME, version=version,
                  instructions="Executable physical worlds fitted from video. Call list_worlds (or create_world), "
                               "get_world_summary to ground objects to ids, then query or edit the world.",
                  on_list_tools=on_list_tools, on_call_tool=on_call_tool, on_list_resources=on_list_resources,
                  on_list_resource_templates=on_list_resource_templates, on_read_resource=on_read_resource)


def mount_mcp(app: Any, registry: Any, pool: Any) -> None:
    """Serve MCP over Streamable HTTP at ``/mcp`` on ``app`` (stateless, JSON responses).

    The session manager runs inside the app's lifespan. Host-header checks
    (DNS-rebinding protection) are off: the server binds where its operator
    says and ``PHYSMIND_API_KEY`` guards ``/mcp`` like ``/v1``.
    """
    server = build_mcp_server(registry, pool, app.version)
    mcp_app = server.streamable_http_app(
        streamable_http_path=MCP_PATH, stateless_http=True, json_response=True,
        transport_security=TransportSecuritySettings(enable_dns_rebinding_protection=False))
    app.router.routes.extend(mcp_app.routes)
    outer = app.router.lifespan_context

    @asynccontextmanager
    async def lifespan(application: Any):
        async with outer(application) as state, server.session_manager.run():
            yield state

    app.router.lifespan_context = lifespan
