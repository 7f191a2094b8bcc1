"""Response descriptions shared by the routers (every error is the envelope of schemas/error.schema.json)."""

from __future__ import annotations

from typing import Any

from server.errors import error_schema

ERROR_STATUSES = {
    "401": "missing or wrong bearer token (only when PHYSMIND_API_KEY is set)",
    "404": "unknown world, rollout, object or tool (lists the valid ids when they are few)",
    "413": "request body too large",
    "415": "request body is not application/json",
    "422": "invalid arguments (JSON pointer to the field) or a limit exceeded",
}
# Extra statuses of the build upload (server/routes_builds.py).
UPLOAD_ERROR_STATUSES = {
    "403": "an upload from a browser origin not on the CORS allow-list",
    "408": "the upload did not arrive within PHYSMIND_BODY_TIMEOUT_S",
    "429": "too many build jobs queued or running (Retry-After)",
    "503": "this server has no build backend",
}


def responses(ok_status: int, ok_schema: dict | None = None, description: str = "OK",
              errors: tuple[str, ...] = tuple(ERROR_STATUSES)) -> dict[str, Any]:
    """OpenAPI ``responses`` of one operation: the success schema and the error envelope."""
    error = {"content": {"application/json": {"schema": {"$ref": "#/components/schemas/Error"}}}}
    out: dict[str, Any] = {
        str(ok_status): {"description": description, "content": {"application/json": {"schema": ok_schema or {"type": "object"}}}},
    }
    for status in errors:
        out[status] = {"description": {**ERROR_STATUSES, **UPLOAD_ERROR_STATUSES}[status], **error}
    return out


def components() -> dict[str, Any]:
    return {"schemas": {"Error": error_schema()}}
