"""The OpenAPI document: the error envelope as a component and the bearer scheme on every /v1 operation."""

from __future__ import annotations

import copy
from typing import Any

from fastapi import FastAPI
from fastapi.openapi.utils import get_openapi

from server.openapi_docs import components

BEARER_SCHEME = "bearer"


def _cap(schema: Any, limit: int) -> None:
    """Lower every integer ``maximum`` in ``schema`` (and its anyOf/allOf branches) to ``limit``, in place."""
    if not isinstance(schema, dict):
        return
    if schema.get("type") == "integer":
        schema["maximum"] = min(schema.get("maximum", limit), limit)
    for key in ("anyOf", "allOf", "oneOf"):
        for branch in schema.get(key, ()):
            _cap(branch, limit)


def _limit_horizons(document: dict[str, Any], max_horizon_frames: int) -> None:
    """Publish this server's horizon limit (PHYSMIND_MAX_HORIZON_FRAMES) on every ``horizon_frames`` argument."""
    for operations in document.get("paths", {}).values():
        for operation in operations.values():
            if not isinstance(operation, dict):
                continue
            for media in operation.get("requestBody", {}).get("content", {}).values():
                properties = media.get("schema", {}).get("properties", {})
                if "horizon_frames" in properties:
                    properties["horizon_frames"] = copy.deepcopy(properties["horizon_frames"])  # schemas are shared
                    _cap(properties["horizon_frames"], max_horizon_frames)


def install_openapi(app: FastAPI, auth_required: bool, max_horizon_frames: int | None = None) -> None:
    """Replace ``app.openapi`` by a cached builder that declares the bearer scheme and the Error schema.

    The scheme is declared whether or not this server has a key, so clients
    and fuzzers see how to authenticate; ``security`` is set on /v1 operations
    only when a key is configured (an empty requirement otherwise).
    """

    def build() -> dict[str, Any]:
        if app.openapi_schema is not None:
            return app.openapi_schema
        document = get_openapi(title=app.title, version=app.version, description=app.description, routes=app.routes)
        parts = document.setdefault("components", {})
        parts.setdefault("schemas", {}).update(components()["schemas"])
        parts["securitySchemes"] = {BEARER_SCHEME: {
            "type": "http", "scheme": "bearer",
            "description": "the server's PHYSMIND_API_KEY; required on /v1/* when the server has one"}}
        for path, operations in document.get("paths", {}).items():
            if not path.startswith("/v1"):
                continue
            for operation in operations.values():
                if isinstance(operation, dict):
                    operation["security"] = [{BEARER_SCHEME: []}] if auth_required else [{}, {BEARER_SCHEME: []}]
        if max_horizon_frames is not None:
            _limit_horizons(document, max_horizon_frames)
        app.openapi_schema = document
        return document

    app.openapi = build  # type: ignore[method-assign]
