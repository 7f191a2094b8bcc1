"""Every tool and endpoint through a real uvicorn process: answers, schemas, errors, limits."""

from __future__ import annotations

import json

import pytest

from tools.registry import call_tool, get_tool, tool_names, validate_result
from tools.session import MemoryRolloutStore, WorldSession


@pytest.fixture(scope="module")
def local_session(scene_builders):
    """The same world in-process: HTTP answers must equal direct calls."""
    return WorldSession("local", scene_builders.six_object_world(), MemoryRolloutStore())


def without_ids(result: dict) -> dict:
    drop = {"rollout_id", "world_id", "edited_rollout_id", "rollout_ids"}
    return {k: v for k, v in result.items() if k not in drop}


READ_ONLY_CALLS = [
    ("check_contact", {"object_a": 0, "object_b": 1}),
    ("check_contact", {"object_a": 3, "object_b": 4, "frame_start": 0, "frame_end": 40}),
    ("check_contact", {"object_a": 0, "object_b": 5}),
    ("get_event_time", {"object_a": 2, "object_b": 1}),
    ("inspect_world_state", {"frame": 20}),
    ("inspect_world_state", {"frame": 100000}),
    ("inspect_object_trajectory", {"object_id": 4, "frame_start": 20, "frame_end": 60, "stride": 4}),
    ("list_events", {"kinds": ["collision", "out"]}),
    ("get_world_summary", {}),
]


@pytest.mark.parametrize("tool, args", READ_ONLY_CALLS)
def test_read_only_tools_over_http_equal_direct_calls(client, world_id, local_session, tool, args):
    response = client.post(f"/v1/worlds/{world_id}/tools/{tool}", json=args)
    assert response.status_code == 200, response.text
    result = response.json()
    validate_result(get_tool(tool), result)
    assert without_ids(result) == without_ids(call_tool(tool, local_session, args))


@pytest.mark.parametrize("tool, args", [
    ("simulate_edit", {"edit_type": "remove_object", "object_id": 1, "trajectory_detail": "summary"}),
    ("simulate_edit", {"edit_type": "set_velocity", "object_id": 0, "value": [2.0, 0.5, 0.0]}),
    ("remove_object", {"object_id": 3}),
])
def test_edit_tools_create_rollouts_usable_by_the_other_tools(client, world_id, local_session, tool, args):
    response = client.post(f"/v1/worlds/{world_id}/tools/{tool}", json=args)
    assert response.status_code == 200, response.text
    result = response.json()
    validate_result(get_tool(tool), result)
    local = call_tool(tool, local_session, args)
    assert without_ids(result) | {"edit_manifest": None} == without_ids(local) | {"edit_manifest": None}
    rollout_id = result["rollout_id"]
    # The new id is registered, listed and answers the rollout-dependent tools.
    listed = client.get(f"/v1/worlds/{world_id}/rollouts").json()["rollouts"]
    assert rollout_id in [r["rollout_id"] for r in listed]
    detail = client.get(f"/v1/worlds/{world_id}/rollouts/{rollout_id}").json()
    assert detail["parent_id"] == "base" and detail["edits"] == result["edit_manifest"]["edits"]
    state = client.post(f"/v1/worlds/{world_id}/tools/inspect_world_state", json={"frame": 30, "rollout_id": rollout_id})
    assert state.status_code == 200 and state.json()["rollout_id"] == rollout_id
    compared = client.post(f"/v1/worlds/{world_id}/tools/compare_rollouts", json={"edited_rollout_id": rollout_id})
    assert compared.status_code == 200
    validate_result(get_tool("compare_rollouts"), compared.json())
    assert compared.json()["edited_rollout_id"] == rollout_id


def test_tools_listing_is_openai_function_format(client):
    listing = client.get("/v1/tools").json()["tools"]
    assert [t["function"]["name"] for t in listing] == tool_names()
    assert all(t["type"] == "function" and t["function"]["parameters"]["type"] == "object" for t in listing)
    one = client.get("/v1/tools/check_contact").json()
    assert one["arguments_schema"]["required"] == ["object_a", "object_b"] and "properties" in one["result_schema"]


def test_world_registry_endpoints(client, world_document):
    created = client.post("/v1/worlds", json={"world": world_document, "name": "to-delete"})
    assert created.status_code == 201
    new_id = created.json()["world_id"]
    assert created.json()["summary"]["object_count"] == len(world_document["bodies"])
    assert new_id in [w["world_id"] for w in client.get("/v1/worlds").json()["worlds"]]
    fetched = client.get(f"/v1/worlds/{new_id}").json()
    assert fetched["world"] == world_document and fetched["name"] == "to-delete" and fetched["rollout_ids"] == ["base"]
    full = client.get(f"/v1/worlds/{new_id}/rollouts/base", params={"detail": "full"}).json()
    assert len(full["rollout"]["body_ids"]) == len(world_document["bodies"])
    assert client.delete(f"/v1/worlds/{new_id}").json() == {"deleted": new_id}
    for method, path in [("GET", f"/v1/worlds/{new_id}"), ("DELETE", f"/v1/worlds/{new_id}"),
                         ("GET", f"/v1/worlds/{new_id}/rollouts"),
                         ("POST", f"/v1/worlds/{new_id}/tools/list_events")]:
        response = client.request(method, path, json={} if method == "POST" else None)
        assert response.status_code == 404 and response.json()["error"]["code"] == "world_not_found"
        # the session's server holds every world its worker's tests made: past 20 the ids are counted, not listed
        assert new_id not in response.json()["error"].get("valid_ids", [])
    assert new_id not in [w["world_id"] for w in client.get("/v1/worlds").json()["worlds"]]


@pytest.mark.parametrize(
    "tool, args, pointer",
    [
        ("check_contact", {"object_a": 0}, "/object_b"),
        ("check_contact", {"object_a": "red", "object_b": 1}, "/object_a"),
        ("inspect_world_state", {"frame": -3}, "/frame"),
        ("inspect_object_trajectory", {"object_id": 1, "stride": 0}, "/stride"),
        ("simulate_edit", {"edit_type": "remove_object"}, "/object_id"),
        ("simulate_edit", {"edit_type": "set_mass", "object_id": 1, "value": 0}, "/value"),
        ("compare_rollouts", {"object_ids": []}, "/object_ids"),
        ("list_events", {"unknown": 1}, "/unknown"),
        ("get_world_summary", [], ""),
    ],
)
def test_schema_errors_are_422_with_a_pointer(client, world_id, tool, args, pointer):
    response = client.post(f"/v1/worlds/{world_id}/tools/{tool}", json=args)
    assert response.status_code == 422
    error = response.json()["error"]
    assert (error["code"], error["tool"], error["pointer"]) == ("invalid_arguments", tool, pointer)
    assert error["message"] and error["expected"] and error["request_id"] == response.headers["x-request-id"]
    assert "Traceback" not in response.text


@pytest.mark.parametrize(
    "path_tool, args, code, pointer",
    [
        ("check_contact", {"object_a": 0, "object_b": 1, "rollout_id": "r-nope"}, "rollout_not_found", "/rollout_id"),
        ("inspect_object_trajectory", {"object_id": 17}, "object_not_found", "/object_id"),
        ("teleport", {}, "tool_not_found", ""),
    ],
)
def test_unknown_ids_are_404_listing_valid_ids(client, world_document, path_tool, args, code, pointer):
    # a world of its own: the session's world holds the rollouts of every test its worker ran (listed up to 20)
    world_id = client.post("/v1/worlds", json={"world": world_document}).json()["world_id"]
    response = client.post(f"/v1/worlds/{world_id}/tools/{path_tool}", json=args)
    assert response.status_code == 404
    error = response.json()["error"]
    assert (error["code"], error["pointer"]) == (code, pointer)
    if code == "rollout_not_found":
        assert "base" in error["valid_ids"]
    elif code == "object_not_found":
        assert error["valid_ids"] == [0, 1, 2, 3, 4, 5]
    else:
        assert error["valid_ids"] == tool_names()


def test_unknown_world_lists_the_worlds(tmp_path, world_document, server_factory):
    """On a server of its own: the session's server may hold more worlds than an error lists (MAX_LISTED_IDS),
    depending on which tests its pytest worker ran first."""
    server = server_factory(tmp_path / "data", tmp_path / "server.log")
    try:
        with server.client() as client:
            world_id = client.post("/v1/worlds", json={"world": world_document}).json()["world_id"]
            response = client.post("/v1/worlds/w-nope/tools/check_contact", json={"object_a": 0, "object_b": 1})
    finally:
        server.stop()
    assert response.status_code == 404 and response.json()["error"]["valid_ids"] == [world_id]


@pytest.mark.parametrize(
    "body, status, code, pointer",
    [
        (b"{not json", 422, "invalid_json", ""),
        (json.dumps({"observations": {}}).encode(), 422, "unsupported_source", "/observations"),
        (json.dumps({}).encode(), 422, "invalid_arguments", "/world"),
        (json.dumps({"world": {"format": "physmind.world/1"}, "extra": 1}).encode(), 422, "invalid_arguments", "/extra"),
        (json.dumps({"world": []}).encode(), 422, "invalid_arguments", "/world"),
    ],
)
def test_invalid_world_bodies(client, body, status, code, pointer):
    response = client.post("/v1/worlds", content=body, headers={"content-type": "application/json"})
    assert response.status_code == status
    assert (response.json()["error"]["code"], response.json()["error"]["pointer"]) == (code, pointer)


def test_world_field_errors_point_into_the_document(client, world_document):
    broken = json.loads(json.dumps(world_document))
    broken["bodies"][2]["mass"] = "heavy"
    response = client.post("/v1/worlds", json={"world": broken})
    assert response.status_code == 422 and response.json()["error"]["pointer"] == "/world/bodies/2/mass"
    overlapping = json.loads(json.dumps(world_document))
    overlapping["bodies"][1]["initial"]["position"] = overlapping["bodies"][0]["initial"]["position"]
    response = client.post("/v1/worlds", json={"world": overlapping})
    assert response.status_code == 422 and response.json()["error"]["code"] == "invalid_world"


def test_request_size_limit_is_413(client, world_id):
    big = b'{"pad": "' + b"x" * (5 * 1024 * 1024) + b'"}'
    response = client.post(f"/v1/worlds/{world_id}/tools/list_events", content=big, headers={"content-type": "application/json"})
    assert response.status_code == 413 and response.json()["error"]["code"] == "payload_too_large"


def test_horizon_limit_is_422(client, world_id):
    response = client.post(f"/v1/worlds/{world_id}/tools/simulate_edit",
                           json={"edit_type": "remove_object", "object_id": 1, "horizon_frames": 6000})
    assert response.status_code == 422
    assert (response.json()["error"]["code"], response.json()["error"]["pointer"]) == ("limit_exceeded", "/horizon_frames")


def test_healthz_docs_and_openapi(client):
    assert client.get("/healthz").json()["status"] == "ok"
    assert client.get("/docs").status_code == 200
    spec = client.get("/openapi.json").json()
    assert {f"/v1/worlds/{{world_id}}/tools/{name}" for name in tool_names()} <= set(spec["paths"])


def test_request_ids_are_echoed_and_logged(client, server):
    response = client.get("/v1/worlds", headers={"X-Request-ID": "trace-abc-123"})
    assert response.headers["x-request-id"] == "trace-abc-123"
    generated = client.get("/v1/worlds").headers["x-request-id"]
    assert generated != "trace-abc-123" and len(generated) == 32
    records = [json.loads(line) for line in server.log_lines() if line.startswith("{")]
    mine = [r for r in records if r.get("request_id") == "trace-abc-123"]
    assert mine and mine[-1]["path"] == "/v1/worlds" and mine[-1]["status"] == 200 and "duration_ms" in mine[-1]


def test_unknown_routes_and_methods_are_structured(client):
    assert client.get("/v2/nothing").json()["error"]["code"] == "route_not_found"
    assert client.put("/v1/worlds").json()["error"]["code"] == "method_not_allowed"


@pytest.mark.parametrize("raw", [b'{"object_a": 0, "object_b": 1, "contact_tolerance": NaN}', b'{"frame": Infinity}'])
def test_non_json_constants_are_rejected(client, world_id, raw):
    response = client.post(f"/v1/worlds/{world_id}/tools/check_contact", content=raw, headers={"content-type": "application/json"})
    assert response.status_code == 422 and response.json()["error"]["code"] == "invalid_json"


def test_body_count_limit(client, world_document):
    crowded = json.loads(json.dumps(world_document))
    template = crowded["bodies"][0]
    crowded["bodies"] = [dict(template, id=i) for i in range(300)]
    response = client.post("/v1/worlds", json={"world": crowded})
    assert response.status_code == 422
    assert (response.json()["error"]["code"], response.json()["error"]["pointer"]) == ("limit_exceeded", "/world/bodies")


def test_world_creation_takes_a_base_horizon(client, world_document):
    created = client.post("/v1/worlds", json={"world": world_document, "horizon_frames": 200})
    assert created.status_code == 201, created.text
    world = created.json()["world_id"]
    rollouts = client.get(f"/v1/worlds/{world}/rollouts").json()["rollouts"]
    assert [(r["rollout_id"], r["horizon_frames"]) for r in rollouts] == [("base", 200)]
    state = client.post(f"/v1/worlds/{world}/tools/inspect_world_state", json={"frame": 199})
    assert state.json()["status"] == "ok"
    for bad in (0, "long", 1.5):
        refused = client.post("/v1/worlds", json={"world": world_document, "horizon_frames": bad})
        assert refused.status_code == 422 and refused.json()["error"]["pointer"] == "/horizon_frames", refused.text
    client.delete(f"/v1/worlds/{world}")
