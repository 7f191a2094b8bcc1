"""Bearer-token auth: on when PHYSMIND_API_KEY is set, off otherwise."""

from __future__ import annotations

import httpx
import pytest


API_KEY = "test-key-5b1f"


@pytest.fixture(scope="module")
def secured(tmp_path_factory, server_factory):
    directory = tmp_path_factory.mktemp("secured")
    process = server_factory(directory / "data", directory / "server.log", {"PHYSMIND_API_KEY": API_KEY})
    yield process
    process.stop()


@pytest.mark.parametrize(
    "headers, status",
    [
        ({}, 401),
        ({"Authorization": "Bearer wrong"}, 401),
        ({"Authorization": f"Basic {API_KEY}"}, 401),
        ({"Authorization": f"Bearer {API_KEY}"}, 200),
        ({"Authorization": f"bearer {API_KEY}"}, 200),
    ],
)
def test_v1_requires_the_bearer_token(secured, headers, status):
    response = httpx.get(secured.url + "/v1/tools", headers=headers)
    assert response.status_code == status
    if status == 401:
        assert response.json()["error"]["code"] == "unauthorized"
        assert response.headers["www-authenticate"] == "Bearer"
        assert API_KEY not in response.text


def test_tools_run_with_the_token_and_not_without(secured, world_document):
    with secured.client() as http:
        created = http.post("/v1/worlds", json={"world": world_document})
        assert created.status_code == 201
        world_id = created.json()["world_id"]
        assert http.post(f"/v1/worlds/{world_id}/tools/list_events", json={}).status_code == 200
    denied = httpx.post(f"{secured.url}/v1/worlds/{world_id}/tools/list_events", json={})
    assert denied.status_code == 401


@pytest.mark.parametrize("path", ["/healthz", "/openapi.json", "/docs"])
def test_health_and_docs_stay_public(secured, path):
    assert httpx.get(secured.url + path).status_code == 200


def test_auth_is_off_without_a_key(server):
    assert httpx.get(server.url + "/v1/tools").status_code == 200


def test_server_log_is_json_lines(server):
    lines = [line for line in server.log_lines() if line.strip()]
    assert lines
    for line in lines:
        assert isinstance(__import__("json").loads(line), dict), line
