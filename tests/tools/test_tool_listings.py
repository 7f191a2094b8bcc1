"""Every tool listing follows its API's documented rules, and the vendors' own SDK types accept it.

Rules checked here are written from each API's documentation, independently of
tools/listings.py: OpenAI chat completions and strict mode (Structured
Outputs' supported subset), the Responses API's flat function tools,
Anthropic's Messages API tools and Gemini's function declarations.
"""

from __future__ import annotations

import re
from typing import Any, get_type_hints

import jsonschema
import pytest
from pydantic import TypeAdapter

from tools.listings import LISTING_FORMATS, tool_listing
from tools.registry import tool_registry

OPENAI_NAME = re.compile(r"^[a-zA-Z0-9_-]{1,64}$")
GEMINI_NAME = re.compile(r"^[a-zA-Z_][a-zA-Z0-9_.:-]{0,63}$")
# Structured Outputs: keywords outside the supported subset make strict mode reject the schema.
OPENAI_STRICT_REJECTED = {"minLength", "maxLength", "uniqueItems", "contains", "minContains", "maxContains",
                          "patternProperties", "unevaluatedProperties", "unevaluatedItems", "propertyNames",
                          "minProperties", "maxProperties", "$schema", "$id", "default"}
GEMINI_SCHEMA_FIELDS = {"type", "format", "description", "nullable", "enum", "maxItems", "minItems", "properties",
                        "required", "minProperties", "maxProperties", "minLength", "maxLength", "pattern", "example",
                        "anyOf", "propertyOrdering", "title", "minimum", "maximum", "items"}
GEMINI_TYPES = {"string", "number", "integer", "boolean", "array", "object"}


def _walk(schema: Any, path: str = "#"):
    """Every subschema with its location."""
    if isinstance(schema, dict):
        yield path, schema
        for key in ("properties",):
            for name, sub in schema.get(key, {}).items():
                yield from _walk(sub, f"{path}/{key}/{name}")
        if "items" in schema:
            yield from _walk(schema["items"], f"{path}/items")
        for i, sub in enumerate(schema.get("anyOf", [])):
            yield from _walk(sub, f"{path}/anyOf/{i}")


def _depth(schema: Any) -> int:
    return 1 + max([_depth(p) for p in schema.get("properties", {}).values()] + [0]) if isinstance(schema, dict) else 0


def _check_typed_dict(kind: Any, value: dict) -> None:
    TypeAdapter(kind).validate_python(value)
    unknown = set(value) - set(get_type_hints(kind))
    assert not unknown, f"{kind.__name__} has no keys {unknown}"


def _parameters(tool: dict, listing_format: str) -> dict:
    return {"openai": lambda: tool["function"]["parameters"], "openai-strict": lambda: tool["function"]["parameters"],
            "responses": lambda: tool["parameters"], "anthropic": lambda: tool["input_schema"]}[listing_format]()


@pytest.mark.parametrize("listing_format", ["openai", "openai-strict", "responses", "anthropic", "gemini"])
def test_no_listing_has_combinators_at_the_top(listing_format):
    """OpenAI refuses oneOf/anyOf/allOf/enum/not at the top of parameters; the rules move into the description."""
    listing = tool_listing(listing_format)
    schemas = ([d["parameters"] for d in listing[0]["functionDeclarations"]] if listing_format == "gemini"
               else [_parameters(t, listing_format) for t in listing])
    for schema in schemas:
        assert schema["type"] == "object"
        assert not {"allOf", "anyOf", "oneOf", "not", "if", "then", "else", "enum"} & set(schema), set(schema)
    names = [d["name"] for d in listing[0]["functionDeclarations"]] if listing_format == "gemini" else [
        t.get("name") or t["function"]["name"] for t in listing]
    simulate_edit = schemas[names.index("simulate_edit")]
    if "allOf" in tool_registry()["simulate_edit"].args_schema:
        assert "Rules:" in simulate_edit["description"] and "set_velocity" in simulate_edit["description"]


def test_every_format_lists_every_tool():
    names = list(tool_registry())
    assert len(names) >= 9 and "simulate_edit" in names  # the seven paper tools and the extras
    for listing_format in LISTING_FORMATS:
        listing = tool_listing(listing_format)
        if listing_format == "gemini":
            listing = listing[0]["functionDeclarations"]
        listed = [t.get("name") or t["function"]["name"] for t in listing]
        assert listed == names, listing_format
    with pytest.raises(ValueError, match="unknown tool listing format"):
        tool_listing("cohere")


def test_openai_chat_completions_listing():
    from openai.types.chat import ChatCompletionFunctionToolParam
    from openai.types.shared_params import FunctionDefinition

    for tool in tool_listing("openai"):
        assert tool["type"] == "function" and OPENAI_NAME.match(tool["function"]["name"])
        assert tool["function"]["parameters"]["type"] == "object"
        _check_typed_dict(ChatCompletionFunctionToolParam, tool)
        _check_typed_dict(FunctionDefinition, tool["function"])
        jsonschema.Draft202012Validator.check_schema(tool["function"]["parameters"])


def _assert_openai_strict(parameters: dict, original: dict, name: str) -> None:
    assert parameters["type"] == "object" and "anyOf" not in parameters, name
    assert _depth(parameters) <= 10
    for where, node in _walk(parameters):
        assert not OPENAI_STRICT_REJECTED & set(node), f"{name} {where}: {OPENAI_STRICT_REJECTED & set(node)}"
        if node.get("type") == "object" or "properties" in node:
            assert node.get("additionalProperties") is False, f"{name} {where}: not closed"
            assert sorted(node.get("required", [])) == sorted(node.get("properties", {})), f"{name} {where}: not all required"
    jsonschema.Draft202012Validator.check_schema(parameters)
    required = set(original.get("required", ()))
    assert set(parameters["properties"]) == set(original["properties"])
    assert "allOf" not in parameters and "if" not in parameters
    for prop, sub in original["properties"].items():
        strict_sub = jsonschema.Draft202012Validator(parameters["properties"][prop])
        assert strict_sub.is_valid(None) is (prop not in required), f"{name}.{prop}: null accepted iff optional"
        if "default" in sub:
            assert strict_sub.is_valid(sub["default"]) and str(sub["default"]) in parameters["properties"][prop]["description"]
        if "enum" in sub:
            assert all(strict_sub.is_valid(v) for v in sub["enum"])


def test_openai_strict_listing():
    from openai.types.chat import ChatCompletionFunctionToolParam

    registry = tool_registry()
    for tool in tool_listing("openai-strict"):
        function = tool["function"]
        assert function["strict"] is True
        _check_typed_dict(ChatCompletionFunctionToolParam, tool)
        _assert_openai_strict(function["parameters"], registry[function["name"]].args_schema, function["name"])


def test_responses_listing_is_flat_and_strict():
    from openai.types.responses import FunctionToolParam

    registry = tool_registry()
    for tool in tool_listing("responses"):
        assert tool["type"] == "function" and "function" not in tool and tool["strict"] is True
        assert OPENAI_NAME.match(tool["name"])
        _check_typed_dict(FunctionToolParam, tool)
        _assert_openai_strict(tool["parameters"], registry[tool["name"]].args_schema, tool["name"])


def test_anthropic_listing():
    from anthropic.types import ToolParam

    for tool in tool_listing("anthropic"):
        assert set(tool) == {"name", "description", "input_schema"}
        assert OPENAI_NAME.match(tool["name"]) and tool["input_schema"]["type"] == "object"
        assert "$schema" not in tool["input_schema"] and "$id" not in tool["input_schema"]
        _check_typed_dict(ToolParam, tool)
        jsonschema.Draft202012Validator.check_schema(tool["input_schema"])


def test_gemini_listing():
    from google.genai import types

    listing = tool_listing("gemini")
    assert len(listing) == 1 and set(listing[0]) == {"functionDeclarations"}
    types.Tool.model_validate(listing[0])  # the SDK's models forbid unknown fields
    for declaration in listing[0]["functionDeclarations"]:
        assert set(declaration) == {"name", "description", "parameters"} and GEMINI_NAME.match(declaration["name"])
        assert declaration["parameters"]["type"] == "object"
        for where, node in _walk(declaration["parameters"]):
            assert set(node) <= GEMINI_SCHEMA_FIELDS, f"{declaration['name']} {where}: {set(node) - GEMINI_SCHEMA_FIELDS}"
            assert "type" not in node or node["type"] in GEMINI_TYPES, f"{declaration['name']} {where}: {node['type']}"
            if "enum" in node:
                assert node.get("type") == "string" and all(isinstance(v, str) for v in node["enum"])
