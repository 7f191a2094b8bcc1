"""The PhysMind tool server: FastAPI app factory.

Endpoints (all JSON; see docs/server.md for a curl walkthrough):

* ``GET  /healthz``                                      liveness (no auth)
* ``GET  /v1/tools``                                     tools in OpenAI function-calling format
* ``GET  /v1/tools/{tool_name}``                         one tool with its argument and result schemas
* ``POST /v1/worlds``                                    create a world from ``{"world": <world document>}``
* ``GET  /v1/worlds``, ``GET|DELETE /v1/worlds/{world_id}``
* ``POST /v1/worlds/{world_id}/tools/{tool_name}``       run a tool; the body is its arguments object
* ``GET  /v1/worlds/{world_id}/rollouts[/{rollout_id}]`` the rollout registry

Every error is ``{"error": {code, tool, pointer, message, expected, [valid_ids], request_id}}``
with status 401, 404, 405, 413 or 422; never a traceback.
"""

from __future__ import annotations

import hmac
import json
import math
import threading
import uuid
from contextlib import asynccontextmanager
from pathlib import Path
from typing import Any, Callable, Literal

import jsonschema
from fastapi import FastAPI, Query, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import Response
from jsonschema.exceptions import best_match
from starlette.concurrency import run_in_threadpool
from starlette.exceptions import HTTPException as StarletteHTTPException

from tools.common import boundaries, event_record
from tools.listings import LISTING_FORMATS, tool_listing
from tools.errors import ToolError, invalid_argument, json_pointer, limit_exceeded, not_found
from tools.registry import (
    call_tool,
    get_tool,
    inline_refs,
    inline_tool_schema,
    tool_registry,
    validation_error_to_tool_error,
)
from tools.session import BASE_ROLLOUT_ID, WorldSession, default_horizon_frames
from world.types import Rollout

from schemas import read_schema
from server.logs import get_logger, now_ms
from server.mcp import MCP_PATH, mount_mcp
from server.settings import Settings
from server.store import SqliteStore, WorldGone

API_VERSION = "0.1.0"
WORLD_SCHEMA_NAME = "world.schema.json"
WORLD_SOURCES = ("world", "observations", "video")
MAX_LISTED_IDS = 100
ERROR_SCHEMA = {
    "type": "object",
    "required": ["error"],
    "properties": {
        "error": {
            "type": "object",
            "required": ["code", "message", "pointer"],
            "properties": {
                "code": {"type": "string"},
                "tool": {"type": ["string", "null"]},
                "pointer": {"type": "string"},
                "message": {"type": "string"},
                "expected": {"type": ["string", "null"]},
                "valid_ids": {"type": "array"},
                "request_id": {"type": "string"},
            },
        }
    },
}


# -- JSON helpers -------------------------------------------------------------------
def _finite(value: Any) -> Any:
    """Replace non-finite floats by None (JSON has no NaN/Infinity)."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_finite(v) for v in value]
    return value


def json_response(payload: Any, status: int = 200, headers: dict[str, str] | None = None) -> Response:
    try:
        body = json.dumps(payload, separators=(",", ":"), allow_nan=False)
    except ValueError:
        body = json.dumps(_finite(payload), separators=(",", ":"), allow_nan=False)
    return Response(content=body, status_code=status, media_type="application/json", headers=headers)


def error_response(error: ToolError, request_id: str | None) -> Response:
    payload = error.to_dict()
    if request_id:
        payload["error"]["request_id"] = request_id
    headers = {"WWW-Authenticate": "Bearer"} if error.status == 401 else None
    return json_response(payload, error.status, headers)


def _request_id(request: Request) -> str | None:
    return request.scope.get("state", {}).get("request_id")


def _note(request: Request, **fields: Any) -> None:
    """Attach fields to this request's log line."""
    request.scope.setdefault("state", {}).setdefault("log_fields", {}).update(fields)


def _reject_constant(name: str) -> Any:
    raise ValueError(f"{name} is not valid JSON")


def _parse_json(raw: bytes, tool: str | None, empty: Any) -> Any:
    if not raw.strip():
        return empty
    try:
        # NaN / Infinity are Python extensions, not JSON: refuse them at the door.
        return json.loads(raw, parse_constant=_reject_constant)
    except (ValueError, RecursionError) as error:
        raise ToolError(code="invalid_json", tool=tool, pointer="", status=422,
                        message=f"request body is not valid JSON: {str(error)[:200]}", expected="a JSON object") from None


# -- registry of worlds and sessions ------------------------------------------------
class WorldRegistry:
    """Worlds and their tool sessions over one SqliteStore (thread-safe)."""

    def __init__(self, store: SqliteStore, settings: Settings) -> None:
        self.store = store
        self.settings = settings
        self._sessions: dict[str, WorldSession] = {}
        self._lock = threading.Lock()
        self._world_validator = self._load_world_validator()

    @staticmethod
    def _load_world_validator() -> Any:
        return jsonschema.Draft202012Validator(read_schema(WORLD_SCHEMA_NAME))

    def world_schema_for_openapi(self) -> dict:
        return inline_refs(read_schema(WORLD_SCHEMA_NAME), read_schema, WORLD_SCHEMA_NAME)

    def unknown_world(self, world_id: str, tool: str | None = None) -> ToolError:
        return not_found("world", world_id, self.store.world_ids()[:MAX_LISTED_IDS], tool=tool, pointer="")

    def session(self, world_id: str, tool: str | None = None) -> WorldSession:
        with self._lock:
            session = self._sessions.get(world_id)
        if session is not None:
            return session
        world = self.store.get_world(world_id)
        if world is None:
            raise self.unknown_world(world_id, tool)
        session = WorldSession(world_id, world, self.store, max_horizon_frames=self.settings.max_horizon_frames)
        with self._lock:
            return self._sessions.setdefault(world_id, session)

    def create_world(self, body: Any) -> dict:
        from world.io import world_from_dict
        from world.rollout import simulate

        if not isinstance(body, dict):
            raise invalid_argument(None, "", "the request body must be a JSON object", '{"world": {...world document...}}')
        for key in body:
            if key not in (*WORLD_SOURCES, "name", "horizon_frames"):
                raise invalid_argument(None, json_pointer([key]), f"unknown property {key!r}",
                                       f"only {[*WORLD_SOURCES, 'name', 'horizon_frames']}")
        sources = [k for k in WORLD_SOURCES if k in body]
        if len(sources) != 1:
            raise invalid_argument(None, "/world", f"give exactly one world source, got {sources or 'none'}",
                                   f"exactly one of {list(WORLD_SOURCES)}")
        if sources[0] != "world":
            raise ToolError(code="unsupported_source", tool=None, pointer=json_pointer([sources[0]]), status=422,
                            message=f"creating a world from {sources[0]!r} is not available in this version; "
                                    "fit it first (physmind fit) and POST the world document under 'world'",
                            expected="a 'world' document")
        name = body.get("name")
        if name is not None and (not isinstance(name, str) or not 0 < len(name) <= 200):
            raise invalid_argument(None, "/name", "name must be a string of 1..200 characters", "a string of 1..200 characters")
        document = body["world"]
        if not isinstance(document, dict):
            raise invalid_argument(None, "/world", "the world document must be a JSON object", "a world document (schemas/world.schema.json)")
        bodies = document.get("bodies")
        if isinstance(bodies, list) and len(bodies) > self.settings.max_bodies:
            raise limit_exceeded(None, "/world/bodies", f"{len(bodies)} bodies exceed this server's limit of "
                                 f"{self.settings.max_bodies}", self.settings.max_bodies)
        if self._world_validator is not None:
            error = best_match(self._world_validator.iter_errors(document))
            if error is not None:
                raise validation_error_to_tool_error(error, None, prefix="/world")
        try:
            world = world_from_dict(document)
        except (ValueError, KeyError, TypeError) as error:
            raise ToolError(code="invalid_world", tool=None, pointer="/world", status=422,
                            message=str(error)[:500], expected="a valid world document (schemas/world.schema.json)") from None
        horizon = body.get("horizon_frames", default_horizon_frames(world))
        if isinstance(horizon, bool) or not isinstance(horizon, int) or horizon < 1:
            raise invalid_argument(None, "/horizon_frames", f"horizon_frames must be an integer >= 1, got {horizon!r}",
                                   "an integer number of frames >= 1")
        if horizon > self.settings.max_horizon_frames:
            raise limit_exceeded(None, "/world/observed_frames",
                                 f"the base rollout would need {horizon} frames, above this server's limit of "
                                 f"{self.settings.max_horizon_frames}", self.settings.max_horizon_frames)
        try:
            base = simulate(world, (), horizon_frames=horizon, rollout_id=BASE_ROLLOUT_ID)
        except ValueError as error:
            raise ToolError(code="invalid_world", tool=None, pointer="/world", status=422,
                            message=str(error)[:500], expected="a world the engine can execute") from None
        world_id = "w-" + uuid.uuid4().hex[:16]
        self.store.create_world(world_id, world, document, base, name=name or world.id)
        session = WorldSession(world_id, world, self.store, max_horizon_frames=self.settings.max_horizon_frames)
        with self._lock:
            self._sessions[world_id] = session
        summary = call_tool("get_world_summary", session, {}, validate_results=self.settings.validate_results)
        return {"world_id": world_id, "name": name or world.id, "rollout_ids": [BASE_ROLLOUT_ID], "summary": summary}

    def delete_world(self, world_id: str) -> dict:
        if not self.store.delete_world(world_id):
            raise self.unknown_world(world_id)
        with self._lock:
            self._sessions.pop(world_id, None)
        return {"deleted": world_id}

    def run_tool(self, world_id: str, tool_name: str, raw: bytes) -> dict:
        get_tool(tool_name)  # 404 listing the tools before anything else
        args = _parse_json(raw, tool_name, {})
        session = self.session(world_id, tool_name)
        try:
            return call_tool(tool_name, session, args, validate_results=self.settings.validate_results)
        except WorldGone:
            with self._lock:
                self._sessions.pop(world_id, None)
            raise self.unknown_world(world_id, tool_name) from None

    def rollout_summary(self, world_id: str, rollout_id: str, detail: str) -> dict:
        session = self.session(world_id)
        rollout: Rollout = session.rollout(rollout_id, tool=None, pointer="")
        row = self.store.rollout_row(world_id, rollout_id)
        payload: dict[str, Any] = {
            "world_id": world_id,
            "rollout_id": rollout_id,
            "parent_id": row.parent_id if row else None,
            "created_at": row.created_at if row else None,
            "edits": row.edits if row else [],
            "object_ids": [int(b) for b in rollout.body_ids],
            "boundaries": boundaries(rollout),
            "events": [event_record(e, rollout.observed_frames) for e in rollout.events],
        }
        if detail == "full":
            payload["rollout"] = self.store.rollout_document(world_id, rollout_id)
        return payload


# -- middleware ----------------------------------------------------------------------
class RequestMiddleware:
    """Pure ASGI: request ids, bearer auth, body size limit (413), JSON access log."""

    PUBLIC_PREFIXES = ("/healthz", "/docs", "/openapi.json", "/redoc")

    def __init__(self, app: Callable, settings: Settings) -> None:
        self.app = app
        self.settings = settings
        self.logger = get_logger(settings.log_level)
        self._api_key = settings.api_key.encode() if settings.api_key else None

    async def __call__(self, scope: dict, receive: Callable, send: Callable) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        started = now_ms()
        headers = {k.decode("latin-1").lower(): v.decode("latin-1") for k, v in scope.get("headers", [])}
        incoming = headers.get("x-request-id", "")
        request_id = incoming if 0 < len(incoming) <= 64 and incoming.isprintable() and incoming.isascii() else uuid.uuid4().hex
        state = scope.setdefault("state", {})
        state["request_id"] = request_id
        status_holder = {"status": 500}

        async def send_with_id(message: dict) -> None:
            if message["type"] == "http.response.start":
                status_holder["status"] = message["status"]
                message.setdefault("headers", [])
                message["headers"] = [*message["headers"], (b"x-request-id", request_id.encode())]
            await send(message)

        path = scope.get("path", "")
        try:
            rejection = self._authorize(path, headers)
            if rejection is None:
                rejection, receive = await self._limit_body(headers, receive)
            if rejection is not None:
                await error_response(rejection, request_id)(scope, receive, send_with_id)
            else:
                await self.app(scope, receive, send_with_id)
        finally:
            fields = {
                "request_id": request_id,
                "method": scope.get("method"),
                "path": path,
                "status": status_holder["status"],
                "duration_ms": round(now_ms() - started, 3),
                "client": (scope.get("client") or ("", 0))[0],
                **state.get("log_fields", {}),
            }
            self.logger.info("request", extra={"fields": fields})

    def _authorize(self, path: str, headers: dict[str, str]) -> ToolError | None:
        if self._api_key is None or not path.startswith(("/v1", MCP_PATH)):
            return None
        given = headers.get("authorization", "")
        scheme, _, token = given.partition(" ")
        if scheme.lower() == "bearer" and hmac.compare_digest(token.strip().encode(), self._api_key):
            return None
        return ToolError(code="unauthorized", tool=None, pointer="", status=401,
                         message="missing or wrong bearer token", expected="header 'Authorization: Bearer <PHYSMIND_API_KEY>'")

    async def _limit_body(self, headers: dict[str, str], receive: Callable) -> tuple[ToolError | None, Callable]:
        limit = self.settings.max_request_bytes

        def too_large(size: str) -> ToolError:
            return ToolError(code="payload_too_large", tool=None, pointer="", status=413,
                             message=f"request body of {size} bytes exceeds the limit of {limit} bytes",
                             expected=f"a body of at most {limit} bytes", extra={"limit": limit})

        declared = headers.get("content-length")
        if declared is not None and declared.isdigit() and int(declared) > limit:
            return too_large(declared), receive
        # Buffer the body (bounded by the limit) so chunked uploads are limited too.
        chunks: list[bytes] = []
        size = 0
        more = True
        while more:
            message = await receive()
            if message["type"] != "http.request":
                break
            chunk = message.get("body", b"")
            size += len(chunk)
            if size > limit:
                return too_large(f"more than {limit}"), receive
            chunks.append(chunk)
            more = message.get("more_body", False)
        body = b"".join(chunks)
        delivered = False

        async def replay() -> dict:
            nonlocal delivered
            if not delivered:
                delivered = True
                return {"type": "http.request", "body": body, "more_body": False}
            return await receive()

        return None, replay


# -- app factory ---------------------------------------------------------------------
def _responses(ok_status: int, ok_schema: dict | None = None, description: str = "OK") -> dict:
    error = {"content": {"application/json": {"schema": ERROR_SCHEMA}}}
    responses: dict[str, Any] = {
        str(ok_status): {"description": description, "content": {"application/json": {"schema": ok_schema or {"type": "object"}}}},
        "401": {"description": "missing or wrong bearer token (only when PHYSMIND_API_KEY is set)", **error},
        "404": {"description": "unknown world, rollout, object or tool (lists the valid ids)", **error},
        "413": {"description": "request body too large", **error},
        "422": {"description": "invalid arguments (JSON pointer to the field) or a limit exceeded", **error},
    }
    return responses


def create_app(settings: Settings | None = None) -> FastAPI:
    """The FastAPI app with its SQLite registry under ``settings.data_dir``."""
    settings = settings or Settings.from_env()
    store = SqliteStore(settings.database_path)
    registry = WorldRegistry(store, settings)
    logger = get_logger(settings.log_level)

    @asynccontextmanager
    async def lifespan(_: FastAPI):
        logger.info("startup", extra={"fields": {"data_dir": str(settings.data_dir), "auth": bool(settings.api_key),
                                                  "tools": list(tool_registry())}})
        yield
        store.close()

    app = FastAPI(
        title="PhysMind tool server",
        version=API_VERSION,
        description="Executable physical worlds served as schema-validated rollout tools. "
                    "Errors are {error: {code, tool, pointer, message, expected}}.",
        lifespan=lifespan,
    )
    app.state.settings = settings
    app.state.registry = registry
    app.state.store = store

    @app.exception_handler(ToolError)
    async def _tool_error(request: Request, error: ToolError) -> Response:
        _note(request, error_code=error.code)
        return error_response(error, _request_id(request))

    @app.exception_handler(RequestValidationError)
    async def _validation_error(request: Request, error: RequestValidationError) -> Response:
        first = (error.errors() or [{}])[0]
        location = [p for p in first.get("loc", ()) if p not in ("query", "path", "body", "header")]
        tool_error = invalid_argument(None, json_pointer(location), str(first.get("msg", "invalid request"))[:300],
                                      str(first.get("ctx", {}).get("expected", "")) or None)
        _note(request, error_code=tool_error.code)
        return error_response(tool_error, _request_id(request))

    @app.exception_handler(StarletteHTTPException)
    async def _http_error(request: Request, error: StarletteHTTPException) -> Response:
        codes = {404: "route_not_found", 405: "method_not_allowed"}
        tool_error = ToolError(code=codes.get(error.status_code, "http_error"), tool=None, pointer="",
                               status=error.status_code, message=str(error.detail), expected=None)
        return error_response(tool_error, _request_id(request))

    @app.exception_handler(Exception)
    async def _internal_error(request: Request, error: Exception) -> Response:
        logger.error("unhandled error", exc_info=error, extra={"fields": {"request_id": _request_id(request)}})
        tool_error = ToolError(code="internal_error", tool=None, pointer="", status=500,
                               message="internal error; the server log has details under this request_id", expected=None)
        return error_response(tool_error, _request_id(request))

    @app.get("/healthz", tags=["meta"], responses=_responses(200))
    def healthz() -> Response:
        return json_response({"status": "ok", "version": API_VERSION, "tools": len(tool_registry())})

    @app.get("/v1/tools", tags=["tools"], responses=_responses(200))
    def list_tools(format: Literal[LISTING_FORMATS] = Query("openai", description="the tool-calling API to list the tools for")) -> Response:  # noqa: A002
        return json_response({"format": format, "tools": tool_listing(format)})

    @app.get("/v1/tools/{tool_name}", tags=["tools"], responses=_responses(200))
    def describe_tool(tool_name: str) -> Response:
        tool = get_tool(tool_name)
        return json_response({
            "name": tool.name, "description": tool.spec.description,
            "arguments_schema": tool.args_schema, "result_schema": inline_tool_schema(f"{tool.name}.result.json"),
        })

    world_body_schema = {
        "type": "object",
        "description": "exactly one source: 'world' (a fitted world document); 'observations' and 'video' are reserved",
        "properties": {
            "world": registry.world_schema_for_openapi(),
            "observations": {"type": "object", "description": "reserved: observations to fit (not yet available)"},
            "video": {"type": "object", "description": "reserved: a video to perceive and fit (not yet available)"},
            "name": {"type": "string", "minLength": 1, "maxLength": 200},
            "horizon_frames": {"type": "integer", "minimum": 1,
                               "description": "frames of the base rollout (default: observed frames + 20 %)"},
        },
        "additionalProperties": False,
    }

    @app.post("/v1/worlds", tags=["worlds"], status_code=201, responses=_responses(201),
              openapi_extra={"requestBody": {"required": True, "content": {"application/json": {"schema": world_body_schema}}}})
    async def create_world(request: Request) -> Response:
        body = _parse_json(await request.body(), None, None)
        result = await run_in_threadpool(registry.create_world, body)
        _note(request, world_id=result["world_id"])
        return json_response(result, 201)

    @app.get("/v1/worlds", tags=["worlds"], responses=_responses(200))
    def list_worlds() -> Response:
        rows = store.list_worlds()
        return json_response({"worlds": [
            {"world_id": r.world_id, "name": r.name, "created_at": r.created_at, "object_count": r.body_count, "rollout_count": r.rollout_count}
            for r in rows
        ]})

    @app.get("/v1/worlds/{world_id}", tags=["worlds"], responses=_responses(200))
    def get_world(world_id: str) -> Response:
        row = store.world_row(world_id)
        document = store.world_document(world_id)
        if row is None or document is None:
            raise registry.unknown_world(world_id)
        return json_response({
            "world_id": world_id, "name": row.name, "created_at": row.created_at, "object_count": row.body_count,
            "rollout_ids": store.rollout_ids(world_id), "world": document,
        })

    @app.delete("/v1/worlds/{world_id}", tags=["worlds"], responses=_responses(200))
    def delete_world(world_id: str) -> Response:
        return json_response(registry.delete_world(world_id))

    @app.get("/v1/worlds/{world_id}/rollouts", tags=["rollouts"], responses=_responses(200))
    def list_rollouts(world_id: str) -> Response:
        registry.session(world_id)
        return json_response({"world_id": world_id, "rollouts": [
            {"rollout_id": r.rollout_id, "parent_id": r.parent_id, "created_at": r.created_at,
             "horizon_frames": r.horizon_frames, "edits": r.edits}
            for r in store.list_rollouts(world_id)
        ]})

    @app.get("/v1/worlds/{world_id}/rollouts/{rollout_id}", tags=["rollouts"], responses=_responses(200))
    def get_rollout(world_id: str, rollout_id: str,
                    detail: Literal["summary", "full"] = Query("summary", description="full adds the per-frame rollout document")) -> Response:
        return json_response(registry.rollout_summary(world_id, rollout_id, detail))

    def make_tool_endpoint(fixed_name: str | None) -> Callable:
        async def run_tool(request: Request, world_id: str, tool_name: str | None = None) -> Response:
            name = fixed_name or tool_name or ""
            _note(request, world_id=world_id, tool=name)
            raw = await request.body()
            result = await run_in_threadpool(registry.run_tool, world_id, name, raw)
            return json_response(result)

        return run_tool

    for tool in tool_registry().values():
        app.add_api_route(
            f"/v1/worlds/{{world_id}}/tools/{tool.name}", make_tool_endpoint(tool.name), methods=["POST"],
            tags=["tools"], summary=tool.name, description=tool.spec.description, name=f"tool_{tool.name}",
            responses=_responses(200, inline_tool_schema(f"{tool.name}.result.json")),
            openapi_extra={"requestBody": {"required": False, "content": {"application/json": {
                "schema": inline_tool_schema(f"{tool.name}.args.json")}}}},
        )
    # Any other name: 404 listing the tools (not in the OpenAPI spec: the routes above are the contract).
    app.add_api_route("/v1/worlds/{world_id}/tools/{tool_name}", make_tool_endpoint(None), methods=["POST"], include_in_schema=False)

    mount_mcp(app, registry)
    app.add_middleware(RequestMiddleware, settings=settings)
    return app
