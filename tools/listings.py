"""The tool listings of every major tool-calling API, generated from the one schema source.

``GET /v1/tools?format=...`` and the MCP server serve these; the argument
schemas are ``schemas/tools/<name>.args.json`` and nothing here restates them.

| format          | shape                                                                                |
|-----------------|--------------------------------------------------------------------------------------|
| ``openai``        | chat completions: ``{"type": "function", "function": {name, description, parameters}}`` |
| ``openai-strict`` | the same with ``"strict": true`` and a strict-mode schema (``strict_schema``)          |
| ``responses``     | OpenAI Responses API, flat: ``{"type": "function", name, description, parameters, strict}`` |
| ``anthropic``     | Messages API: ``{name, description, input_schema}``                                      |
| ``gemini``        | ``{"functionDeclarations": [{name, description, parameters}]}`` (OpenAPI-subset schema) |

Strict mode sends every property; an optional one the model leaves out
arrives as ``null``, which the server treats as "use the default"
(``tools.registry.without_null_optionals``). Defaults therefore move from the
``default`` keyword (which strict mode and Gemini do not take) into the
description.
"""

from __future__ import annotations

import copy
import json
from typing import Any, Callable

from tools.registry import tool_registry

LISTING_FORMATS = ("openai", "openai-strict", "responses", "anthropic", "gemini")

# Combinators the function-calling APIs refuse at the top of a parameters schema
# (OpenAI: "must be type object and not have oneOf/anyOf/allOf/enum/not at the
# top level"). The server still validates with them; the listing states their
# rules in words.
TOP_LEVEL_COMBINATORS = ("allOf", "anyOf", "oneOf", "not", "if", "then", "else", "enum")

# Keywords OpenAI's strict mode rejects (Structured Outputs, "supported schemas"),
# plus the ones it ignores that we move into the description (default, title).
STRICT_DROPPED_KEYWORDS = frozenset({
    "$schema", "$id", "$comment", "title", "default", "examples",
    "minLength", "maxLength", "uniqueItems", "contains", "minContains", "maxContains",
    "unevaluatedItems", "unevaluatedProperties", "patternProperties", "propertyNames",
    "minProperties", "maxProperties",
})
# Keywords of JSON Schema that Gemini's OpenAPI-subset Schema object has no field for.
GEMINI_DROPPED_KEYWORDS = frozenset({
    "$schema", "$id", "$comment", "default", "examples", "additionalProperties", "uniqueItems", "const",
    "exclusiveMinimum", "exclusiveMaximum", "patternProperties", "propertyNames", "contains",
})


def _with_default_in_description(node: dict) -> dict:
    """``node`` whose description says its default (the ``default`` keyword is about to go)."""
    if "default" not in node:
        return node
    described = dict(node)
    text = described.get("description", "")
    note = f"default {json.dumps(node['default'])}; null also means the default"
    described["description"] = f"{text} ({note})" if text else note
    return described


def _nullable(node: dict) -> dict:
    """``node`` that also accepts null (the strict-mode form of an optional property)."""
    nullable = dict(node)
    if "anyOf" in nullable:
        nullable["anyOf"] = [*nullable["anyOf"], {"type": "null"}]
        return nullable
    kind = nullable.get("type")
    if isinstance(kind, str):
        nullable["type"] = [kind, "null"]
    elif isinstance(kind, list) and "null" not in kind:
        nullable["type"] = [*kind, "null"]
    if "enum" in nullable and None not in nullable["enum"]:
        nullable["enum"] = [*nullable["enum"], None]
    return nullable


def strict_schema(schema: Any) -> Any:
    """An argument schema in OpenAI strict-mode form.

    Every object is closed (``additionalProperties: false``) and lists every
    property as required; properties that were optional accept null; keywords
    strict mode rejects are dropped (defaults go into the description).
    """
    if isinstance(schema, list):
        return [strict_schema(item) for item in schema]
    if not isinstance(schema, dict):
        return schema
    node = _with_default_in_description(schema)
    out = {key: strict_schema(value) for key, value in node.items()
           if key not in STRICT_DROPPED_KEYWORDS and key not in ("properties", "required")}
    if "properties" in node or node.get("type") == "object":
        properties = node.get("properties", {})
        required = set(node.get("required", ()))
        out["properties"] = {
            name: strict_schema(prop) if name in required else _nullable(strict_schema(prop))
            for name, prop in properties.items()
        }
        out["required"] = list(properties)
        out["additionalProperties"] = False
    return out


def gemini_schema(schema: Any) -> Any:
    """An argument schema as Gemini's Schema object (an OpenAPI 3.0 subset).

    Type lists such as ``["integer", "null"]`` become ``type`` + ``nullable``;
    ``const`` becomes a one-value ``enum``; keywords without a Schema field are
    dropped (defaults go into the description).
    """
    if isinstance(schema, list):
        return [gemini_schema(item) for item in schema]
    if not isinstance(schema, dict):
        return schema
    node = _with_default_in_description(schema)
    out: dict[str, Any] = {}
    for key, value in node.items():
        if key in GEMINI_DROPPED_KEYWORDS:
            continue
        if key == "properties":
            out[key] = {name: gemini_schema(prop) for name, prop in value.items()}
        elif key == "type" and isinstance(value, list):
            kinds = [k for k in value if k != "null"]
            out["type"] = kinds[0] if len(kinds) == 1 else kinds  # several non-null types: left as is
            if "null" in value:
                out["nullable"] = True
        else:
            out[key] = gemini_schema(value)
    if "const" in node:
        out["enum"] = [node["const"]]
    if "enum" in out and "type" not in out and all(isinstance(v, str) for v in out["enum"]):
        out["type"] = "string"  # Gemini enums are typed strings
    return out


def listed_parameters(schema: dict) -> dict:
    """An argument schema as every listing starts from: no document keywords, no top-level combinators.

    Rules written as top-level ``allOf``/``if``/``then`` (e.g. simulate_edit's
    "set_velocity needs value") move into the description, one sentence each.
    """
    public = copy.deepcopy(schema)
    for key in ("$schema", "$id"):
        public.pop(key, None)
    rules: list[str] = []
    for key in TOP_LEVEL_COMBINATORS:
        removed = public.pop(key, None)
        for part in removed if isinstance(removed, list) else ([removed] if isinstance(removed, dict) else []):
            if isinstance(part, dict) and part.get("description"):
                rules.append(part["description"])
    if rules:
        text = public.get("description", "")
        public["description"] = (f"{text} " if text else "") + "Rules: " + "; ".join(rules) + "."
    return public


def _openai() -> list[dict]:
    return [{"type": "function", "function": {"name": tool.name, "description": tool.spec.description,
                                              "parameters": listed_parameters(tool.args_schema)}}
            for tool in tool_registry().values()]


def _openai_strict() -> list[dict]:
    return [{"type": "function", "function": {"name": tool.name, "description": tool.spec.description,
                                              "parameters": strict_schema(listed_parameters(tool.args_schema)), "strict": True}}
            for tool in tool_registry().values()]


def _responses() -> list[dict]:
    return [{"type": "function", "name": tool.name, "description": tool.spec.description,
             "parameters": strict_schema(listed_parameters(tool.args_schema)), "strict": True}
            for tool in tool_registry().values()]


def _anthropic() -> list[dict]:
    return [{"name": tool.name, "description": tool.spec.description, "input_schema": listed_parameters(tool.args_schema)}
            for tool in tool_registry().values()]


def _gemini() -> list[dict]:
    return [{"functionDeclarations": [
        {"name": tool.name, "description": tool.spec.description, "parameters": gemini_schema(listed_parameters(tool.args_schema))}
        for tool in tool_registry().values()]}]


_BUILDERS: dict[str, Callable[[], list[dict]]] = {
    "openai": _openai, "openai-strict": _openai_strict, "responses": _responses,
    "anthropic": _anthropic, "gemini": _gemini,
}


def tool_listing(listing_format: str = "openai") -> list[dict]:
    """The tools in ``listing_format`` (one of LISTING_FORMATS), ready to pass as ``tools=``.

    Raises:
        ValueError: an unknown format.
    """
    if listing_format not in _BUILDERS:
        raise ValueError(f"unknown tool listing format {listing_format!r}; expected one of {list(LISTING_FORMATS)}")
    return _BUILDERS[listing_format]()
