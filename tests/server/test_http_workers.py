"""The worker processes of a real server: a world deleted through one process is gone in all of them."""

from __future__ import annotations


def test_deleted_world_is_gone_in_every_worker(client, world_document):
    world_id = client.post("/v1/worlds", json={"world": world_document}).json()["world_id"]
    for _ in range(6):  # warm the caches of every worker
        assert client.get(f"/v1/worlds/{world_id}/rollouts/base?detail=full").status_code == 200
        assert client.post(f"/v1/worlds/{world_id}/tools/list_events", json={}).status_code == 200
    assert client.delete(f"/v1/worlds/{world_id}").status_code == 200
    for _ in range(6):
        assert client.get(f"/v1/worlds/{world_id}/rollouts/base?detail=full").status_code == 404
        assert client.post(f"/v1/worlds/{world_id}/tools/list_events", json={}).status_code == 404
