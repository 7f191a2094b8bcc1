"""The registry: every tool has valid schemas, an OpenAI listing, and structured argument errors."""

from __future__ import annotations

import json
import re
from pathlib import Path

import jsonschema
import pytest

from schemas import read_schema, schema_names
from tools.errors import ToolError
from tools.registry import (
    call_tool,
    get_tool,
    inline_tool_schema,
    openai_tools,
    tool_names,
    tool_registry,
    validate_result,
)

TOOLS_DIR = Path(__file__).resolve().parents[2] / "tools"
PAPER_TOOLS = ["simulate_edit", "check_contact", "get_event_time", "compare_rollouts",
               "inspect_world_state", "inspect_object_trajectory", "remove_object"]


def test_the_seven_paper_tools_come_first_then_the_extras():
    assert tool_names()[:7] == PAPER_TOOLS
    assert set(tool_names()[7:]) == {"list_events", "get_world_summary", "continue_world"}


@pytest.mark.parametrize("name", tool_names())
@pytest.mark.parametrize("kind", ["args", "result"])
def test_schema_files_are_valid_draft_2020_12(name, kind):
    document = read_schema(f"tools/{name}.{kind}.json")
    assert document["$schema"] == "https://json-schema.org/draft/2020-12/schema"
    jsonschema.Draft202012Validator.check_schema(document)


@pytest.mark.parametrize("name", tool_names())
def test_argument_schemas_are_closed_self_contained_objects(name):
    schema = get_tool(name).args_schema
    assert schema["type"] == "object" and schema["additionalProperties"] is False
    assert "$ref" not in json.dumps(schema)  # function-calling clients do not resolve references
    assert "$ref" not in json.dumps(inline_tool_schema(f"{name}.result.json"))


def test_openai_listing_has_function_entries_for_every_tool():
    listing = openai_tools()
    assert [t["function"]["name"] for t in listing] == tool_names()
    for entry in listing:
        assert entry["type"] == "function"
        function = entry["function"]
        assert len(function["description"]) > 40
        assert function["parameters"]["type"] == "object"
        assert "$schema" not in function["parameters"] and "$id" not in function["parameters"]


def test_every_tool_module_is_discovered_with_its_schemas():
    # Found independently of the registry's discovery: the modules whose source declares a ToolSpec.
    declaring = {path.stem for path in TOOLS_DIR.glob("*.py") if re.search(r"^TOOL = ToolSpec\(", path.read_text(), re.M)}
    assert len(declaring) >= 9
    assert set(tool_registry()) == declaring
    files = schema_names("tools")
    assert {name.removesuffix(".args.json") for name in files if name.endswith(".args.json")} == declaring
    assert {name.removesuffix(".result.json") for name in files if name.endswith(".result.json")} == declaring


@pytest.mark.parametrize(
    "tool, args, pointer, expected_fragment",
    [
        ("check_contact", {"object_a": 0}, "/object_b", "required"),
        ("check_contact", {"object_a": 0, "object_b": "x"}, "/object_b", "integer"),
        ("check_contact", {"object_a": 0, "object_b": 1, "frame_start": -1}, "/frame_start", ">= 0"),
        ("check_contact", {"object_a": 0, "object_b": 1, "bogus": True}, "/bogus", "only the properties"),
        ("check_contact", {"object_a": True, "object_b": 1}, "/object_a", "integer"),
        ("inspect_world_state", {}, "/frame", "required"),
        ("inspect_world_state", {"frame": 1.5}, "/frame", "integer"),
        ("simulate_edit", {"edit_type": "explode", "object_id": 1}, "/edit_type", "one of"),
        ("simulate_edit", {"edit_type": "set_velocity", "object_id": 1, "value": [1, 2]}, "/value", "at least 3 items"),
        ("simulate_edit", {"edit_type": "remove_object", "object_id": 1, "trajectory_detail": "all"}, "/trajectory_detail", "one of"),
        ("compare_rollouts", {"object_ids": [1, 1]}, "/object_ids", "duplicates"),
        ("list_events", {"kinds": ["explosion"]}, "/kinds/0", "one of"),
        ("get_world_summary", {"x": 1}, "/x", "only the properties"),
    ],
)
def test_invalid_arguments_name_the_field(session, tool, args, pointer, expected_fragment):
    with pytest.raises(ToolError) as caught:
        call_tool(tool, session, args)
    error = caught.value
    assert (error.code, error.status, error.tool, error.pointer) == ("invalid_arguments", 422, tool, pointer)
    assert expected_fragment and expected_fragment in (error.expected or "")
    body = error.to_dict()["error"]
    assert set(body) >= {"code", "tool", "pointer", "message", "expected"}


@pytest.mark.parametrize("args", [[], "x", 3, None])
def test_non_object_arguments_are_rejected_at_the_root(session, args):
    with pytest.raises(ToolError) as caught:
        call_tool("list_events", session, args)
    assert caught.value.pointer == "" and caught.value.status == 422


def test_unknown_tool_lists_the_tools(session):
    with pytest.raises(ToolError) as caught:
        call_tool("teleport", session, {})
    assert caught.value.status == 404 and list(caught.value.valid_ids) == tool_names()


def test_result_validation_catches_a_broken_result(session):
    good = call_tool("list_events", session, {})
    validate_result(get_tool("list_events"), good)
    broken = dict(good)
    del broken["count"]
    with pytest.raises(AssertionError, match="list_events result violates its schema"):
        validate_result(get_tool("list_events"), broken)
