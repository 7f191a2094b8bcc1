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


def _not_null(schema: dict | None) -> dict:
    return {"not": {"type": "null"}} if schema is None else {"allOf": [schema, {"not": {"type": "null"}}]}


def _or_null(schema: dict) -> dict:
    if schema.get("not") == {}:  # a forbidden property may still be sent as null: null means absent
        return {"type": "null"}
    return {"anyOf": [schema, {"type": "null"}]}


def _null_aware_rule(rule: dict, optional: set[str]) -> dict:
    """One ``if``/``then`` rule of an argument schema, with null meaning "absent" for the optional properties."""
    rule = dict(rule)
    if isinstance(rule.get("if"), dict):
        condition = {**rule["if"], "properties": dict(rule["if"].get("properties", {}))}
        for name in set(condition.get("required", ())) & optional:  # present = present and not null
            condition["properties"][name] = _not_null(condition["properties"].get(name))
        rule["if"] = condition
    if isinstance(rule.get("then"), dict):
        outcome = {**rule["then"], "properties": dict(rule["then"].get("properties", {}))}
        for name, schema in list(outcome["properties"].items()):
            if name in optional:
                outcome["properties"][name] = (_not_null(schema) if name in outcome.get("required", ())
                                               else _or_null(schema))
        for name in set(outcome.get("required", ())) & optional - set(outcome["properties"]):
            outcome["properties"][name] = _not_null(None)
        rule["then"] = outcome
    return rule


def published_args_schema(schema: dict) -> dict:
    """A tool's argument schema as the HTTP API accepts it: an optional property may be null (its default).

    The tools drop null optional arguments before validating
    (``tools.registry.without_null_optionals``: OpenAI's strict mode sends every
    property); the published contract says so, including inside the
    ``if``/``then`` rules, so that a fuzzer's null is neither a surprise
    acceptance nor a surprise refusal.
    """
    optional = set(schema.get("properties", {})) - set(schema.get("required", ()))
    published = dict(schema)
    published["properties"] = {name: (_or_null(p) if name in optional else p) for name, p in schema.get("properties", {}).items()}
    if isinstance(schema.get("allOf"), list):
        published["allOf"] = [_null_aware_rule(rule, optional) if isinstance(rule, dict) else rule for rule in schema["allOf"]]
    return published
