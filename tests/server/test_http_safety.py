"""Safe by default: trusted Host, JSON-only bodies, CORS off unless listed, offline docs, the published contract.

In-process (TestClient, worker threads) so each case costs milliseconds; the
real-process behaviour is covered by the other server tests.
"""

from __future__ import annotations

import copy

import jsonschema
import pytest
from fastapi.testclient import TestClient

from schemas import read_schema
from server.app import create_app
from server.contract import response_schema
from server.settings import Settings
from tools.registry import get_tool, validate_result

LOCAL = "http://localhost"


def make_client(tmp_path, **overrides) -> TestClient:
    settings = Settings(data_dir=tmp_path / "data", workers=0, log_level="WARNING", **overrides)
    return TestClient(create_app(settings), base_url=LOCAL)


@pytest.fixture()
def http(tmp_path):
    with make_client(tmp_path) as client:
        yield client


@pytest.fixture()
def world_id(http, world_document):
    response = http.post("/v1/worlds", json={"world": world_document})
    assert response.status_code == 201, response.text
    return response.json()["world_id"]


def assert_envelope(response, status: int, code: str) -> dict:
    assert response.status_code == status, response.text
    body = response.json()
    jsonschema.validate(body, read_schema("error.schema.json"))
    assert body["error"]["code"] == code, body
    return body["error"]


# -- Host header (DNS rebinding) ------------------------------------------------------
@pytest.mark.parametrize("host", ["localhost", "localhost:8000", "127.0.0.1:9", "[::1]:8000"])
def test_loopback_hosts_are_accepted(http, host):
    assert http.get("/healthz", headers={"host": host}).status_code == 200


@pytest.mark.parametrize("host", ["evil.example", "evil.example:8000", "127.0.0.1.evil.example"])
def test_other_hosts_are_refused(http, host):
    assert_envelope(http.get("/v1/tools", headers={"host": host}), 400, "untrusted_host")


def test_trusted_hosts_option_adds_names(tmp_path):
    with make_client(tmp_path, trusted_hosts=("physmind.internal",)) as client:
        assert client.get("/healthz", headers={"host": "physmind.internal:8000"}).status_code == 200
        assert client.get("/healthz", headers={"host": "other.internal"}).status_code == 400


# -- JSON-only bodies (no cross-site simple requests) --------------------------------
@pytest.mark.parametrize("content_type", ["text/plain", "application/x-www-form-urlencoded", "multipart/form-data; boundary=x"])
def test_non_json_bodies_are_415_and_store_nothing(http, world_document, content_type):
    import json

    response = http.post("/v1/worlds", content=json.dumps({"world": world_document}), headers={"content-type": content_type})
    assert_envelope(response, 415, "unsupported_media_type")
    assert http.get("/v1/worlds").json()["worlds"] == []


def test_form_encoded_tool_call_is_415(http, world_id):
    response = http.post(f"/v1/worlds/{world_id}/tools/simulate_edit", content="edit_type=remove_object&object_id=1",
                         headers={"content-type": "application/x-www-form-urlencoded"})
    assert_envelope(response, 415, "unsupported_media_type")
    assert http.get(f"/v1/worlds/{world_id}/rollouts").json()["rollouts"][-1]["rollout_id"] == "base"


def test_json_with_charset_and_empty_tool_body_are_accepted(http, world_id):
    ok = http.post(f"/v1/worlds/{world_id}/tools/list_events", content=b"{}",
                   headers={"content-type": "application/json; charset=utf-8"})
    assert ok.status_code == 200
    assert http.post(f"/v1/worlds/{world_id}/tools/list_events").status_code == 200


# -- CORS -----------------------------------------------------------------------------
def test_cors_is_off_by_default(http):
    response = http.options("/v1/tools", headers={"origin": "https://evil.example", "access-control-request-method": "GET"})
    assert "access-control-allow-origin" not in response.headers
    assert "access-control-allow-origin" not in http.get("/v1/tools", headers={"origin": "https://evil.example"}).headers


def test_cors_allow_list(tmp_path):
    with make_client(tmp_path, cors_origins=("https://app.example",)) as client:
        allowed = client.get("/v1/tools", headers={"origin": "https://app.example"})
        assert allowed.headers.get("access-control-allow-origin") == "https://app.example"
        other = client.get("/v1/tools", headers={"origin": "https://evil.example"})
        assert "access-control-allow-origin" not in other.headers


# -- docs and the OpenAPI contract ------------------------------------------------------
def test_docs_page_loads_its_assets_from_this_server(http):
    page = http.get("/docs")
    assert page.status_code == 200
    assert "cdn" not in page.text.lower() and "https://" not in page.text
    for asset in ("/docs/assets/swagger-ui-bundle.js", "/docs/assets/swagger-ui.css"):
        assert asset in page.text
        response = http.get(asset)
        assert response.status_code == 200 and len(response.content) > 10_000


def test_openapi_declares_bearer_short_ids_and_typed_responses(http):
    spec = http.get("/openapi.json").json()
    assert spec["components"]["securitySchemes"]["bearer"] == {
        "type": "http", "scheme": "bearer", "description": spec["components"]["securitySchemes"]["bearer"]["description"]}
    operations = {(method, path): op for path, ops in spec["paths"].items() for method, op in ops.items()}
    ids = [op["operationId"] for op in operations.values()]
    assert len(ids) == len(set(ids)) and max(len(i) for i in ids) <= 30, ids
    assert operations[("post", "/v1/worlds/{world_id}/tools/check_contact")]["operationId"] == "check_contact"
    for (method, path), op in operations.items():
        if path.startswith("/v1"):
            assert {"bearer": []} in op["security"], path
        ok = next(v for k, v in op["responses"].items() if k.startswith("2"))
        assert ok["content"]["application/json"]["schema"] != {"type": "object"}, (method, path)
        for status, response in op["responses"].items():
            if status.startswith("4"):
                assert response["content"]["application/json"]["schema"] == {"$ref": "#/components/schemas/Error"}


def test_openapi_security_is_required_when_the_server_has_a_key(tmp_path):
    with make_client(tmp_path, api_key="k") as client:
        spec = client.get("/openapi.json").json()
    assert spec["paths"]["/v1/worlds"]["get"]["security"] == [{"bearer": []}]


def test_responses_match_their_published_schemas(http, world_document):
    created = http.post("/v1/worlds", json={"world": world_document})
    jsonschema.validate(created.json(), response_schema("world_created"))
    world_id = created.json()["world_id"]
    edit = http.post(f"/v1/worlds/{world_id}/tools/simulate_edit", json={"edit_type": "set_velocity", "object_id": 0,
                                                                          "value": [1.0, 0.5, 0.0]})
    validate_result(get_tool("simulate_edit"), edit.json())
    rollout_id = edit.json()["rollout_id"]
    checks = {
        "/healthz": "health", "/v1/tools": "tool_listing", "/v1/tools/check_contact": "tool_description",
        "/v1/worlds": "world_list", f"/v1/worlds/{world_id}": "world_detail",
        f"/v1/worlds/{world_id}/rollouts": "rollout_list", f"/v1/worlds/{world_id}/rollouts/{rollout_id}": "rollout_detail",
        f"/v1/worlds/{world_id}/rollouts/{rollout_id}?detail=full": "rollout_detail",
    }
    for path, name in checks.items():
        response = http.get(path)
        assert response.status_code == 200, path
        jsonschema.validate(response.json(), response_schema(name))
    jsonschema.validate(http.delete(f"/v1/worlds/{world_id}").json(), response_schema("world_deleted"))


# -- clean errors ---------------------------------------------------------------------
def test_405_lists_every_allowed_method(http, world_id):
    response = http.put(f"/v1/worlds/{world_id}", json={})
    error = assert_envelope(response, 405, "method_not_allowed")
    assert response.headers["allow"] == "DELETE, GET" and error["allow"] == ["DELETE", "GET"]


def test_echoed_input_is_truncated_and_long_id_lists_are_not_echoed(http, world_document):
    for _ in range(25):
        assert http.post("/v1/worlds", json={"world": world_document}).status_code == 201
    response = http.post(f"/v1/worlds/{'x' * 10_000}/tools/list_events", json={})
    error = assert_envelope(response, 404, "world_not_found")
    assert len(response.content) < 1000 and "valid_ids" not in error and "25 world ids" in error["message"]


def test_few_ids_are_still_listed(http, world_id):
    error = assert_envelope(http.post(f"/v1/worlds/{world_id}/tools/list_events", json={"rollout_id": "r-" + "y" * 60}),
                            404, "rollout_not_found")
    assert error["valid_ids"] == ["base"] and len(error["message"]) < 200


@pytest.mark.parametrize("where", ["name", "world_id_string", "key"])
def test_lone_surrogates_are_422_and_store_nothing(http, world_document, where):
    document = copy.deepcopy(world_document)
    raw = {"world": document, "name": "ok"}
    import json

    text = json.dumps(raw)
    if where == "name":
        text = text.replace('"ok"', '"\\ud800"')
    elif where == "world_id_string":
        text = text.replace(f'"id": "{document["id"]}"', '"id": "a\\udfffb"', 1)
    else:
        text = text.replace('"name"', '"\\ud800"')
    response = http.post("/v1/worlds", content=text, headers={"content-type": "application/json"})
    assert_envelope(response, 422, "invalid_json")
    assert http.get("/v1/worlds").json()["worlds"] == []


def test_lone_surrogate_in_tool_arguments(http, world_id):
    response = http.post(f"/v1/worlds/{world_id}/tools/list_events", content='{"rollout_id": "\\ud800"}',
                         headers={"content-type": "application/json"})
    assert assert_envelope(response, 422, "invalid_json")["pointer"] == "/rollout_id"


@pytest.mark.parametrize("path, value, pointer", [
    (("bodies", 0, "mass"), 4e-7, "/world/bodies/0/mass"),
    (("bodies", 0, "initial", "velocity", 0), 1e300, "/world/bodies/0/initial/velocity/0"),
    (("fps",), 1e-300, "/world/fps"),
    (("bodies", 1, "initial", "position", 2), -1e9, "/world/bodies/1/initial/position/2"),
])
def test_absurd_worlds_are_refused_before_anything_is_stored(http, world_document, path, value, pointer):
    document = copy.deepcopy(world_document)
    node = document
    for key in path[:-1]:
        node = node[key]
    node[path[-1]] = value
    error = assert_envelope(http.post("/v1/worlds", json={"world": document}), 422, "invalid_arguments")
    assert error["pointer"] == pointer
    assert http.get("/v1/worlds").json()["worlds"] == []


def test_list_events_clips_a_start_beyond_the_horizon(http, world_id):
    response = http.post(f"/v1/worlds/{world_id}/tools/list_events", json={"frame_start": 10_000})
    assert response.status_code == 200, response.text
    assert response.json()["count"] == 0 and response.json()["range"]["frame_start"] == 10_000
    error = assert_envelope(http.post(f"/v1/worlds/{world_id}/tools/list_events", json={"frame_start": 20, "frame_end": 10}),
                            422, "invalid_arguments")
    assert error["pointer"] == "/frame_end"
