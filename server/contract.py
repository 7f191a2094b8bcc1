"""The published response schemas of the meta, world and rollout endpoints (schemas/http.schema.json), inlined.

Inlined (no $ref) so that they embed in the OpenAPI document as they are,
and tests can validate real responses against exactly what is published.
"""

from __future__ import annotations

from functools import lru_cache

from schemas import read_schema
from tools.registry import TOOL_SCHEMA_FOLDER, inline_refs

HTTP_SCHEMA_NAME = "http.schema.json"


def _load(name: str) -> dict:
    # Refs are relative to the referring file: tool schemas say "common.json" for "tools/common.json".
    try:
        return read_schema(name)
    except FileNotFoundError:
        return read_schema(f"{TOOL_SCHEMA_FOLDER}/{name}")


@lru_cache(maxsize=None)
def response_schema(name: str) -> dict:
    """The inlined schema ``$defs/<name>`` of schemas/http.schema.json (e.g. ``world_created``)."""
    document = read_schema(HTTP_SCHEMA_NAME)
    if name not in document["$defs"]:
        raise KeyError(f"no response schema {name!r} in {HTTP_SCHEMA_NAME}")
    return inline_refs({"$ref": f"{HTTP_SCHEMA_NAME}#/$defs/{name}"}, _load)
