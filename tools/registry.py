"""The tool registry: name -> implementation + argument schema + result schema.

One registry feeds the HTTP server, the OpenAI function-calling listing and
(later) MCP. A tool is a module in ``tools/`` that defines ``TOOL = ToolSpec(...)``;
its schemas are ``schemas/tools/<name>.args.json`` and ``<name>.result.json``
(JSON Schema draft 2020-12). Adding a tool is one module plus its two schemas.
"""

from __future__ import annotations

import copy
import importlib
import json
import pkgutil
from dataclasses import dataclass, field
from functools import lru_cache
from typing import Any, Callable, Mapping

import jsonschema
from jsonschema.exceptions import ValidationError, best_match
from referencing import Registry, Resource

import tools as package
from schemas import read_schema, schema_names
from tools.errors import ToolError, invalid_argument, json_pointer, not_available_in_3d, not_found

TOOL_SCHEMA_FOLDER = "tools"

ToolFunction = Callable[[Any, Mapping[str, Any]], dict]


@dataclass(frozen=True)
class ToolSpec:
    """A tool: ``run(session, args) -> result``; ``order`` sorts the public listing.

    ``run3d``: the tool on a 3D world (a session with ``is_3d``); without it
    the tool answers 422 ``not_available_in_3d`` there.
    ``read_only``: the tool only reads the world and its rollouts (repeating a
    call changes nothing). A tool that is not read-only adds a rollout; no
    tool deletes anything. MCP's tool annotations are derived from it.
    """

    name: str
    description: str
    run: ToolFunction
    order: int = 100
    read_only: bool = True
    run3d: ToolFunction | None = None  # the tool on a 3D world (tools.scene3d); None: not available there


@dataclass(frozen=True)
class RegisteredTool:
    spec: ToolSpec
    args_schema: dict
    result_schema: dict
    args_validator: Any = field(repr=False)
    result_validator: Any = field(repr=False)
    fast_result_validator: Any = field(default=None, repr=False)

    @property
    def name(self) -> str:
        return self.spec.name


@lru_cache(maxsize=1)
def _schema_registry() -> Registry:
    resources = []
    for name in schema_names(TOOL_SCHEMA_FOLDER):
        document = load_schema(name)
        resources.append((document["$id"], Resource.from_contents(document)))
    return Registry().with_resources(resources)


def load_schema(filename: str) -> dict:
    """A tool schema file of ``schemas/tools/`` (e.g. ``check_contact.args.json``)."""
    return read_schema(f"{TOOL_SCHEMA_FOLDER}/{filename}")


def _validator(schema: dict) -> Any:
    jsonschema.Draft202012Validator.check_schema(schema)
    return jsonschema.Draft202012Validator(schema, registry=_schema_registry())


@lru_cache(maxsize=1)
def tool_registry() -> dict[str, RegisteredTool]:
    """All tools found in the ``tools`` package, in listing order."""
    specs: list[ToolSpec] = []
    for info in pkgutil.iter_modules(package.__path__):
        module = importlib.import_module(f"tools.{info.name}")
        spec = getattr(module, "TOOL", None)
        if isinstance(spec, ToolSpec):
            specs.append(spec)
    specs.sort(key=lambda s: (s.order, s.name))
    registry: dict[str, RegisteredTool] = {}
    for spec in specs:
        args_schema = load_schema(f"{spec.name}.args.json")
        result_schema = load_schema(f"{spec.name}.result.json")
        registry[spec.name] = RegisteredTool(
            spec, args_schema, result_schema, _validator(args_schema), _validator(result_schema),
            _fast_validator(inline_tool_schema(f"{spec.name}.result.json")),
        )
    return registry


def _fast_validator(schema: dict) -> Any:
    """A compiled (Rust) validator when jsonschema_rs is installed, else None.

    Result validation runs on every server call: the pure-Python validator
    costs ~1.5 ms on an inspection result, jsonschema_rs ~0.01 ms. Python
    jsonschema still produces the error message when a result is invalid.
    """
    try:
        import jsonschema_rs
    except ImportError:
        return None
    return jsonschema_rs.Draft202012Validator(schema)


def tool_names() -> list[str]:
    return list(tool_registry())


def get_tool(name: str) -> RegisteredTool:
    registry = tool_registry()
    if name not in registry:
        raise not_found("tool", name, list(registry), tool=None, pointer="")
    return registry[name]


def _public_schema(schema: dict) -> dict:
    """A schema without the document keywords ($schema, $id) that function-calling APIs reject."""
    public = copy.deepcopy(schema)
    public.pop("$schema", None)
    public.pop("$id", None)
    return public


def openai_tools() -> list[dict]:
    """The tools in OpenAI function-calling format: [{"type": "function", "function": {...}}]."""
    return [
        {
            "type": "function",
            "function": {
                "name": tool.name,
                "description": tool.spec.description,
                "parameters": _public_schema(tool.args_schema),
            },
        }
        for tool in tool_registry().values()
    ]


def _expected(error: ValidationError) -> str:
    keyword, value = error.validator, error.validator_value
    words = {
        "type": lambda: f"a value of type {value}",
        "enum": lambda: f"one of {value}",
        "const": lambda: f"exactly {json.dumps(value)}",
        "minimum": lambda: f"a number >= {value}",
        "maximum": lambda: f"a number <= {value}",
        "exclusiveMinimum": lambda: f"a number > {value}",
        "exclusiveMaximum": lambda: f"a number < {value}",
        "minItems": lambda: f"at least {value} items",
        "maxItems": lambda: f"at most {value} items",
        "minLength": lambda: f"a string of at least {value} characters",
        "maxLength": lambda: f"a string of at most {value} characters",
        "pattern": lambda: f"a string matching {value}",
        "required": lambda: f"the required properties {value}",
        "additionalProperties": lambda: f"only the properties {sorted(error.schema.get('properties', {}))}",
        "uniqueItems": lambda: "items without duplicates",
    }
    if keyword in words:
        return words[keyword]()
    return f"{keyword}: {json.dumps(value, default=str)[:200]}"


def validation_error_to_tool_error(error: ValidationError, tool: str | None, prefix: str = "") -> ToolError:
    """A jsonschema error as a ToolError whose pointer names the offending field."""
    path = list(error.absolute_path)
    message = error.message
    if error.validator == "required" and isinstance(error.instance, dict):
        missing = [p for p in error.validator_value if p not in error.instance]
        if missing:
            path.append(missing[0])
            message = f"missing required property {missing[0]!r}"
    elif error.validator == "additionalProperties" and isinstance(error.instance, dict):
        allowed = set(error.schema.get("properties", {}))
        extra = sorted(str(k) for k in error.instance if k not in allowed)
        if extra:
            path.append(extra[0])
            message = f"unknown property {extra[0]!r}"
    elif error.validator == "not" and isinstance(error.schema, dict) and error.schema.get("description"):
        message = f"{error.schema['description']}; got {json.dumps(error.instance, default=str)[:80]}"  # a rule of the schema's allOf
    if len(message) > 300:
        message = message[:300] + "..."
    return invalid_argument(tool, prefix + json_pointer(path), message, _expected(error))


def validate_args(tool: RegisteredTool, args: Any) -> None:
    error = best_match(tool.args_validator.iter_errors(args))
    if error is not None:
        raise validation_error_to_tool_error(error, tool.name)


def validate_result(tool: RegisteredTool, result: Any) -> None:
    """Raise AssertionError (a bug, not a user error) if a result breaks its schema."""
    if tool.fast_result_validator is not None and tool.fast_result_validator.is_valid(result):
        return
    error = best_match(tool.result_validator.iter_errors(result))
    if error is not None:
        raise AssertionError(f"{tool.name} result violates its schema at {json_pointer(error.absolute_path)!r}: {error.message[:300]}")


def without_null_optionals(args: Any, schema: Mapping[str, Any]) -> Any:
    """``args`` without the optional properties whose value is null: null means "use the default".

    OpenAI's strict mode (and MCP hosts built on it) must send every property,
    so an omitted optional arrives as null. A null for a required property is
    kept, so validation still reports it. Only the top level has optional
    properties in the tool schemas; a non-object ``args`` is returned as is.
    """
    if not isinstance(args, dict):
        return args
    required = set(schema.get("required", ()))
    return {key: value for key, value in args.items() if value is not None or key in required}


def call_tool(name: str, session: Any, args: Any, *, validate_results: bool = True) -> dict:
    """Validate ``args``, run the tool on ``session``, validate its result.

    A null optional argument takes its default (``without_null_optionals``).
    Raises ToolError for invalid arguments or unknown ids (never a traceback);
    a result that breaks its schema is a bug and raises AssertionError.
    """
    tool = get_tool(name)
    args = without_null_optionals(args, tool.args_schema)
    run = tool.spec.run
    if getattr(session, "is_3d", False):
        if tool.spec.run3d is None:
            raise not_available_in_3d(tool.name, [t.name for t in tool_registry().values() if t.spec.run3d is not None], tool.name)
        run = tool.spec.run3d
    validate_args(tool, args)
    try:
        result = run(session, args)
    except ToolError as error:
        if error.tool is None:
            error.tool = tool.name
        raise
    if validate_results:
        validate_result(tool, result)
    return result


def inline_refs(schema: dict, load: Callable[[str], dict], filename: str = "") -> dict:
    """A copy of ``schema`` with every $ref replaced by its target (for embedding in OpenAPI).

    ``load(filename)`` returns another schema document for cross-file refs
    ("common.json#/$defs/event"); "#/..." refs resolve within ``filename``.
    Document keywords ($schema, $id, $defs) are dropped. Recursion is cut at
    depth 40 (the remainder becomes the permissive schema {}).
    """
    documents: dict[str, dict] = {filename: schema}

    def document(name: str) -> dict:
        if name not in documents:
            documents[name] = load(name)
        return documents[name]

    def resolve(node: Any, current: str, depth: int) -> Any:
        if depth > 40:
            return {}
        if isinstance(node, dict):
            if "$ref" in node:
                target_file, _, fragment = str(node["$ref"]).partition("#")
                target_file = target_file or current
                target: Any = document(target_file)
                for part in [p for p in fragment.split("/") if p]:
                    target = target[part.replace("~1", "/").replace("~0", "~")]
                resolved = resolve(target, target_file, depth + 1)
                rest = {k: resolve(v, current, depth + 1) for k, v in node.items() if k != "$ref"}
                return {**resolved, **rest} if rest else resolved
            return {k: resolve(v, current, depth + 1) for k, v in node.items() if k not in ("$schema", "$id", "$defs")}
        if isinstance(node, list):
            return [resolve(v, current, depth + 1) for v in node]
        return node

    return resolve(schema, filename, 0)


def inline_tool_schema(filename: str) -> dict:
    """A tool schema from schemas/tools/ with all $refs inlined (self-contained)."""
    return inline_refs(load_schema(filename), load_schema, filename)
