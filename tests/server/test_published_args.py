"""The published argument schemas (OpenAPI) accept exactly what the server accepts: null optionals are their defaults."""

from __future__ import annotations

import jsonschema
import pytest

from server.contract import published_args_schema
from tools.registry import get_tool, inline_tool_schema, without_null_optionals

CASES = [  # (tool, arguments)
    ("simulate_edit", {"edit_type": "remove_object", "object_id": 0, "value": None}),
    ("simulate_edit", {"edit_type": "remove_object", "object_id": 0, "value": 1.0}),
    ("simulate_edit", {"edit_type": "set_velocity", "object_id": 0, "value": None}),
    ("simulate_edit", {"edit_type": "set_velocity", "object_id": 0, "value": [1.0, 0.0, 0.0]}),
    ("simulate_edit", {"edit_type": "set_mass", "object_id": 0, "value": 2.0, "other_object_id": None}),
    ("simulate_edit", {"edit_type": "set_mass", "object_id": 0, "value": 2.0, "other_object_id": 1}),
    ("simulate_edit", {"edit_type": "set_restitution", "object_id": 0, "value": 0.5, "other_object_id": None}),
    ("simulate_edit", {"edit_type": "set_restitution", "object_id": 0, "value": 0.5, "other_object_id": 1}),
    ("simulate_edit", {"edit_type": "set_mass", "object_id": None, "value": 2.0}),
    ("simulate_edit", {"edit_type": "set_mass", "object_id": 0, "value": 2.0, "sample_every": None, "based_on": None}),
    ("inspect_world_state", {"frame": 0, "rollout_id": None}),
    ("inspect_world_state", {"frame": None}),
    ("inspect_object_trajectory", {"object_id": 0, "stride": None, "frame_end": None}),
    ("list_events", {"frame_end": None, "kinds": None}),
    ("list_events", {"kinds": ["in", None]}),
    ("remove_object", {"object_id": 0, "sample_every": None, "horizon_frames": None}),
    ("check_contact", {"object_a": 0, "object_b": 1, "frame_start": None, "contact_tolerance": None}),
]


def _accepted_by_server(tool: str, args: dict) -> bool:
    schema = get_tool(tool).args_schema
    return jsonschema.Draft202012Validator(schema).is_valid(without_null_optionals(args, schema))


@pytest.mark.parametrize("tool, args", CASES)
def test_published_schema_agrees_with_the_server(tool, args):
    published = published_args_schema(inline_tool_schema(f"{tool}.args.json"))
    jsonschema.Draft202012Validator.check_schema(published)
    assert jsonschema.Draft202012Validator(published).is_valid(args) == _accepted_by_server(tool, args)


def test_the_cases_cover_both_answers():
    answers = {_accepted_by_server(tool, args) for tool, args in CASES}
    assert answers == {True, False}


def test_openapi_publishes_this_servers_horizon_limit(tmp_path):
    from server.app import create_app
    from server.settings import Settings

    app = create_app(Settings(data_dir=tmp_path, workers=0, max_horizon_frames=777))
    limited = []
    for path, operations in app.openapi()["paths"].items():
        for operation in operations.values():
            for media in operation.get("requestBody", {}).get("content", {}).values():
                horizon = media["schema"].get("properties", {}).get("horizon_frames")
                if horizon is not None:
                    validator = jsonschema.Draft202012Validator(horizon)
                    assert validator.is_valid(777) and not validator.is_valid(778), path
                    limited.append(path)
    app.state.store.close()
    assert {"/v1/worlds", "/v1/worlds/{world_id}/tools/continue_world", "/v1/worlds/{world_id}/tools/simulate_edit"} <= set(limited)
