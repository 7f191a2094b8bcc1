"""MCP with the SDK's own client, over Streamable HTTP (/mcp on the running server) and stdio (`physmind mcp`)."""

from __future__ import annotations

import asyncio
import json
import os
import sys
from pathlib import Path

import httpx
import pytest
from mcp import Client
from mcp.client.stdio import StdioServerParameters
from mcp.shared.exceptions import MCPError

from tools.registry import tool_registry

REPO = Path(__file__).resolve().parents[2]


def _stdio_params(data_dir: Path) -> StdioServerParameters:
    env = {k: v for k, v in os.environ.items() if not k.startswith("PHYSMIND_")}
    return StdioServerParameters(command=sys.executable, args=["-m", "physmind.cli", "mcp", "--data-dir", str(data_dir)],
                                 env=env, cwd=str(REPO))


@pytest.fixture(params=["http", "stdio"])
def mcp_target(request, server, tmp_path):
    return server.url + "/mcp" if request.param == "http" else _stdio_params(tmp_path / "data")


async def _session_checks(target, world_document) -> dict:
    async with Client(target) as client:
        listed = {tool.name: tool for tool in (await client.list_tools()).tools}
        created = await client.call_tool("create_world", {"world": world_document, "name": "mcp-test", "horizon_frames": None})
        assert not created.is_error, created.content
        world_id = created.structured_content["world_id"]
        contact = await client.call_tool("check_contact", {"world_id": world_id, "object_a": 0, "object_b": 1,
                                                          "rollout_id": None, "frame_end": None})
        edit = await client.call_tool("simulate_edit", {"world_id": world_id, "edit_type": "remove_object", "object_id": 1,
                                                       "trajectory_detail": "summary"})
        rollout_id = edit.structured_content["rollout_id"]
        after = await client.call_tool("check_contact", {"world_id": world_id, "object_a": 0, "object_b": 2, "rollout_id": rollout_id})
        bad = await client.call_tool("check_contact", {"world_id": world_id, "object_a": 0, "object_b": "red"})
        no_world = await client.call_tool("list_events", {"world_id": "w-nope"})
        worlds = await client.call_tool("list_worlds", {})
        resource = await client.read_resource(f"physmind://worlds/{world_id}")
        with pytest.raises(MCPError) as unknown:
            await client.call_tool("teleport", {"world_id": world_id})
        return dict(listed=listed, world_id=world_id, contact=contact, edit=edit, after=after, bad=bad, no_world=no_world,
                    worlds=worlds, resource=resource, unknown=unknown.value)


def test_mcp_tools_over_both_transports(mcp_target, world_document):
    got = asyncio.run(_session_checks(mcp_target, world_document))
    listed = got["listed"]
    assert set(listed) == {"list_worlds", "create_world", *tool_registry()}
    for name, tool in tool_registry().items():
        schema = listed[name].input_schema
        assert schema["required"][0] == "world_id" and set(schema["properties"]) == {"world_id", *tool.args_schema["properties"]}
        assert listed[name].output_schema["type"] == "object"
        annotations = listed[name].annotations
        assert annotations.read_only_hint is tool.spec.read_only and annotations.destructive_hint is False
    assert listed["check_contact"].annotations.read_only_hint and listed["check_contact"].annotations.idempotent_hint
    assert not listed["simulate_edit"].annotations.read_only_hint and not listed["simulate_edit"].annotations.idempotent_hint

    contact = got["contact"]
    assert not contact.is_error and contact.structured_content["status"] == "collision"
    assert contact.structured_content["rollout_id"] == "base"  # the null rollout_id took its default
    assert json.loads(contact.content[0].text) == contact.structured_content
    assert got["edit"].structured_content["rollout_id"].startswith("r-")
    after = got["after"].structured_content
    assert after["rollout_id"] == got["edit"].structured_content["rollout_id"] and after["base_comparison"] is not None

    bad = got["bad"]
    assert bad.is_error and bad.structured_content["error"]["code"] == "invalid_arguments"
    assert bad.structured_content["error"]["pointer"] == "/object_b" and "/object_b" in bad.content[0].text
    assert got["no_world"].is_error and got["no_world"].structured_content["error"]["code"] == "world_not_found"
    assert got["world_id"] in {w["world_id"] for w in got["worlds"].structured_content["worlds"]}
    assert json.loads(got["resource"].contents[0].text)["world_id"] == got["world_id"]
    assert "teleport" in got["unknown"].message


def test_mcp_results_equal_http_results(server, client, world_id):
    args = {"object_a": 0, "object_b": 1, "frame_start": 0, "frame_end": 60}
    over_http = client.post(f"/v1/worlds/{world_id}/tools/check_contact", json=args).json()

    async def call():
        async with Client(server.url + "/mcp") as mcp_client:
            return await mcp_client.call_tool("check_contact", {"world_id": world_id, **args})

    assert asyncio.run(call()).structured_content == over_http


def test_http_treats_null_optionals_as_defaults(client, world_id):
    nulls = {"rollout_id": None, "frame_start": None, "frame_end": None, "contact_tolerance": None, "frame_tolerance": None}
    with_nulls = client.post(f"/v1/worlds/{world_id}/tools/check_contact", json={"object_a": 0, "object_b": 1, **nulls})
    assert with_nulls.status_code == 200, with_nulls.text
    omitted = client.post(f"/v1/worlds/{world_id}/tools/check_contact", json={"object_a": 0, "object_b": 1}).json()
    assert with_nulls.json() == omitted
    required_null = client.post(f"/v1/worlds/{world_id}/tools/check_contact", json={"object_a": 0, "object_b": None})
    assert required_null.status_code == 422 and required_null.json()["error"]["pointer"] == "/object_b"


@pytest.mark.parametrize("listing_format", ["openai", "openai-strict", "responses", "anthropic", "gemini"])
def test_tool_listing_formats_over_http(client, listing_format):
    response = client.get("/v1/tools", params={"format": listing_format})
    assert response.status_code == 200 and response.json()["format"] == listing_format
    assert client.get("/v1/tools", params={"format": "cohere"}).status_code == 422


def test_mcp_needs_the_api_key_when_set(server_factory, tmp_path, world_document):
    secured = server_factory(tmp_path / "data", tmp_path / "log", {"PHYSMIND_API_KEY": "s3cret"})
    try:
        async def list_with(headers):
            import httpx2
            async with httpx2.AsyncClient(headers=headers) as http:
                from mcp.client.streamable_http import streamable_http_client
                async with Client(streamable_http_client(secured.url + "/mcp", http_client=http)) as mcp_client:
                    return len((await mcp_client.list_tools()).tools)

        assert asyncio.run(list_with({"Authorization": "Bearer s3cret"})) == len(tool_registry()) + 2  # + list_worlds, create_world
        unauthorized = httpx.post(secured.url + "/mcp", json={"jsonrpc": "2.0", "id": 1, "method": "tools/list"})
        assert unauthorized.status_code == 401 and unauthorized.json()["error"]["code"] == "unauthorized"
    finally:
        secured.stop()
