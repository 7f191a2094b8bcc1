"""The server's one error module: the error envelope, JSON bodies, and the exception handlers.

Every HTTP error, whatever raised it, leaves through ``error_response`` as
``{"error": {code, tool, pointer, message, expected, ...}}`` (the contract is
``schemas/error.schema.json``), with the request id, and never a traceback.
"""

from __future__ import annotations

import json
import logging
import math
from typing import Any

from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import Response
from starlette.exceptions import HTTPException as StarletteHTTPException
from starlette.routing import Match

from schemas import read_schema
from tools.errors import ToolError, invalid_argument, json_pointer

ERROR_SCHEMA_NAME = "error.schema.json"


def error_schema() -> dict:
    """The error envelope's JSON Schema, without the document keywords OpenAPI does not need."""
    schema = read_schema(ERROR_SCHEMA_NAME)
    return {k: v for k, v in schema.items() if k not in ("$schema", "$id")}


# -- JSON bodies ---------------------------------------------------------------------
def _finite(value: Any) -> Any:
    """Replace non-finite floats by None (JSON has no NaN/Infinity)."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_finite(v) for v in value]
    return value


def json_bytes(payload: Any) -> bytes:
    try:
        return json.dumps(payload, separators=(",", ":"), allow_nan=False).encode()
    except ValueError:
        return json.dumps(_finite(payload), separators=(",", ":"), allow_nan=False).encode()


def encoded_response(body: bytes, status: int = 200) -> Response:
    """A response whose JSON body is already encoded (by a worker)."""
    return Response(content=body, status_code=status, media_type="application/json")


def json_response(payload: Any, status: int = 200, headers: dict[str, str] | None = None) -> Response:
    return Response(content=json_bytes(payload), status_code=status, media_type="application/json", headers=headers)


def error_response(error: ToolError, request_id: str | None) -> Response:
    payload = error.to_dict()
    if request_id:
        payload["error"]["request_id"] = request_id
    headers: dict[str, str] = {}
    if error.status == 401:
        headers["WWW-Authenticate"] = "Bearer"
    if "allow" in error.extra:
        headers["Allow"] = ", ".join(error.extra["allow"])
    if "retry_after_s" in error.extra:
        headers["Retry-After"] = str(max(1, math.ceil(error.extra["retry_after_s"])))
    return json_response(payload, error.status, headers or None)


def request_id(request: Request) -> str | None:
    return request.scope.get("state", {}).get("request_id")


def note(request: Request, **fields: Any) -> None:
    """Attach fields to this request's log line."""
    request.scope.setdefault("state", {}).setdefault("log_fields", {}).update(fields)


# -- request bodies ------------------------------------------------------------------
def _reject_constant(name: str) -> Any:
    raise ValueError(f"{name} is not valid JSON")


def parse_json(raw: bytes, tool: str | None, empty: Any) -> Any:
    """The JSON request body (``empty`` for a blank body); NaN/Infinity and bad UTF-8 answer 422."""
    if not raw.strip():
        return empty
    try:
        # NaN / Infinity are Python extensions, not JSON: refuse them at the door.
        value = json.loads(raw, parse_constant=_reject_constant)
    except (ValueError, RecursionError) as error:
        raise ToolError(code="invalid_json", tool=tool, pointer="", status=422,
                        message=f"request body is not valid JSON: {str(error)[:200]}", expected="a JSON object") from None
    bad = _lone_surrogate(value, [])
    if bad is not None:
        raise ToolError(code="invalid_json", tool=tool, pointer=json_pointer(bad), status=422,
                        message="a string holds a lone UTF-16 surrogate (e.g. \\ud800), which is not Unicode text",
                        expected="strings of valid Unicode characters")
    return value


def _lone_surrogate(value: Any, path: list) -> list | None:
    """The path to the first string (key or value) with a lone surrogate, or None."""
    if isinstance(value, str):
        try:
            value.encode("utf-8")
        except UnicodeEncodeError:
            return path
        return None
    if isinstance(value, dict):
        for key, item in value.items():
            found = _lone_surrogate(key, [*path, key]) if isinstance(key, str) else None
            found = found if found is not None else _lone_surrogate(item, [*path, key])
            if found is not None:
                return [p.encode("utf-8", "backslashreplace").decode() if isinstance(p, str) else p for p in found]
        return None
    if isinstance(value, list):
        for index, item in enumerate(value):
            found = _lone_surrogate(item, [*path, index])
            if found is not None:
                return found
    return None


def allowed_methods(request: Request) -> list[str]:
    """Every method some route accepts on this path (Starlette's own 405 names only the first route's)."""
    scope = {**request.scope, "method": "\0"}
    methods: set[str] = set()

    def visit(routes: Any) -> None:
        for route in routes:
            nested = getattr(route, "original_router", None)  # FastAPI wraps included routers
            if nested is not None:
                visit(nested.routes)
            elif route.matches(scope)[0] is Match.PARTIAL:
                methods.update(getattr(route, "methods", None) or ())

    visit(request.app.router.routes)
    return sorted(methods)


# -- exception handlers ----------------------------------------------------------------
def install_error_handlers(app: FastAPI, logger: logging.Logger) -> None:
    """Route every exception, ours or the framework's, through ``error_response``."""

    @app.exception_handler(ToolError)
    async def _tool_error(request: Request, error: ToolError) -> Response:
        note(request, error_code=error.code)
        return error_response(error, request_id(request))

    @app.exception_handler(RequestValidationError)
    async def _validation_error(request: Request, error: RequestValidationError) -> Response:
        first = (error.errors() or [{}])[0]
        location = [p for p in first.get("loc", ()) if p not in ("query", "path", "body", "header")]
        tool_error = invalid_argument(None, json_pointer(location), str(first.get("msg", "invalid request"))[:300],
                                      str(first.get("ctx", {}).get("expected", "")) or None)
        note(request, error_code=tool_error.code)
        return error_response(tool_error, request_id(request))

    @app.exception_handler(StarletteHTTPException)
    async def _http_error(request: Request, error: StarletteHTTPException) -> Response:
        codes = {404: "route_not_found", 405: "method_not_allowed"}
        extra: dict[str, Any] = {}
        if error.status_code == 405:
            extra["allow"] = allowed_methods(request)
        tool_error = ToolError(code=codes.get(error.status_code, "http_error"), tool=None, pointer="",
                               status=error.status_code, message=str(error.detail), expected=None, extra=extra)
        return error_response(tool_error, request_id(request))

    @app.exception_handler(Exception)
    async def _internal_error(request: Request, error: Exception) -> Response:
        logger.error("unhandled error", exc_info=error, extra={"fields": {"request_id": request_id(request)}})
        tool_error = ToolError(code="internal_error", tool=None, pointer="", status=500,
                               message="internal error; the server log has details under this request_id", expected=None)
        return error_response(tool_error, request_id(request))
