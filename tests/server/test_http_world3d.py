"""A 3D world (Physion++-style) over HTTP: registered by POST /v1/worlds, answered by the tools that have a 3D meaning."""

from __future__ import annotations

import pytest

from tools.registry import call_tool, tool_registry
from tools.scene3d import World3DSession
from world.scene3d.io import world3d_to_dict


@pytest.fixture(scope="module")
def world3d(scene_builders):
    return scene_builders.sliding_world3d(0.6)


@pytest.fixture(scope="module")
def world3d_id(client, world3d) -> str:
    response = client.post("/v1/worlds", json={"world": world3d_to_dict(world3d), "name": "sliding cubes"})
    assert response.status_code == 201, response.text
    body = response.json()
    assert body["name"] == "sliding cubes" and body["summary"]["world_format"] == "physmind.world3d/1"
    return body["world_id"]


def test_contact_over_http_equals_the_direct_call(client, world3d, world3d_id):
    local = World3DSession("local", world3d)
    for tool, args in (("check_contact", {"object_a": 0, "object_b": 1}),
                       ("continue_world", {"horizon_frames": 90}),
                       ("list_events", {"rollout_id": "continue-90"}),
                       ("check_contact", {"object_a": 0, "object_b": 1, "rollout_id": "continue-90", "frame_end": 40})):
        response = client.post(f"/v1/worlds/{world3d_id}/tools/{tool}", json=args)
        assert response.status_code == 200, response.text
        remote, direct = response.json(), call_tool(tool, local, args)
        remote.pop("world_id", None), direct.pop("world_id", None)
        assert remote == direct
    answer = client.post(f"/v1/worlds/{world3d_id}/tools/check_contact", json={"object_a": 0, "object_b": 1}).json()
    assert answer["contact"] is True and answer["fitted_properties"][0]["kind"] == "friction"


def test_the_stored_document_reads_back(client, world3d, world3d_id):
    detail = client.get(f"/v1/worlds/{world3d_id}").json()
    assert detail["world"] == world3d_to_dict(world3d) and detail["object_count"] == 2


def test_tools_and_endpoints_without_a_3d_meaning_answer_422(client, world3d_id):
    refused = [name for name, tool in tool_registry().items() if tool.spec.run3d is None]
    for name in refused:
        response = client.post(f"/v1/worlds/{world3d_id}/tools/{name}", json={})
        assert response.status_code == 422 and response.json()["error"]["code"] == "not_available_in_3d", (name, response.text)
    for path in (f"/v1/worlds/{world3d_id}/rollouts/base", f"/v1/worlds/{world3d_id}/rollouts/base/plot.png"):
        response = client.get(path)
        assert response.status_code == 422 and response.json()["error"]["code"] == "not_available_in_3d", (path, response.text)


def test_an_invalid_3d_world_is_refused_with_a_pointer(client, world3d):
    document = world3d_to_dict(world3d)
    document["bodies"][0]["restitution"] = 2.0
    response = client.post("/v1/worlds", json={"world": document})
    assert response.status_code == 422
    error = response.json()["error"]
    assert error["code"] == "invalid_world" and error["pointer"] == "/world" and "restitution" in error["message"]
    document = world3d_to_dict(world3d)
    document["anchor"]["states"][0]["object_id"] = 9
    response = client.post("/v1/worlds", json={"world": document})
    assert response.status_code == 422 and "unknown bodies [9]" in response.json()["error"]["message"]
