"""32 clients creating rollouts on one world at once: all ids distinct, all retrievable."""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import httpx
import pytest

CLIENTS = 32


@pytest.mark.slow
def test_parallel_rollout_creation(server, world_document):
    with server.client() as http:
        world_id = http.post("/v1/worlds", json={"world": world_document}).json()["world_id"]

    def create(index: int) -> tuple[str, int]:
        object_id = index % len(world_document["bodies"])
        args = {"edit_type": "remove_object", "object_id": object_id, "trajectory_detail": "summary"}
        with httpx.Client(base_url=server.url, timeout=120.0) as http:
            response = http.post(f"/v1/worlds/{world_id}/tools/simulate_edit", json=args)
        assert response.status_code == 200, response.text
        return response.json()["rollout_id"], object_id

    with ThreadPoolExecutor(CLIENTS) as pool:
        created = list(pool.map(create, range(CLIENTS)))
    ids = [rollout_id for rollout_id, _ in created]
    assert len(set(ids)) == CLIENTS

    with server.client() as http:
        listed = [r["rollout_id"] for r in http.get(f"/v1/worlds/{world_id}/rollouts").json()["rollouts"]]
        assert sorted(listed) == sorted(["base", *ids])  # one base, computed once
        for rollout_id, object_id in created:
            detail = http.get(f"/v1/worlds/{world_id}/rollouts/{rollout_id}")
            assert detail.status_code == 200
            assert detail.json()["edits"][0]["object_id"] == object_id
            assert object_id not in detail.json()["object_ids"]
            trajectory = http.post(f"/v1/worlds/{world_id}/tools/inspect_object_trajectory",
                                   json={"object_id": object_id, "rollout_id": rollout_id})
            assert trajectory.json()["count"] == 0  # removed from the start


@pytest.mark.slow
def test_parallel_world_creation_and_reads(server, world_document):
    def create_and_read(_: int) -> str:
        with httpx.Client(base_url=server.url, timeout=120.0) as http:
            world_id = http.post("/v1/worlds", json={"world": world_document}).json()["world_id"]
            state = http.post(f"/v1/worlds/{world_id}/tools/inspect_world_state", json={"frame": 10})
            assert state.status_code == 200
            return world_id

    with ThreadPoolExecutor(16) as pool:
        world_ids = list(pool.map(create_and_read, range(16)))
    assert len(set(world_ids)) == 16
    with server.client() as http:
        known = {w["world_id"] for w in http.get("/v1/worlds").json()["worlds"]}
    assert set(world_ids) <= known
