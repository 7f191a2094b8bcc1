"""The worker processes of a real server: a world deleted through one process is gone in all of them."""

from __future__ import annotations

import os
import signal
import time
from pathlib import Path

import pytest


def test_deleted_world_is_gone_in_every_worker(client, world_document):
    world_id = client.post("/v1/worlds", json={"world": world_document}).json()["world_id"]
    for _ in range(6):  # warm the caches of every worker
        assert client.get(f"/v1/worlds/{world_id}/rollouts/base?detail=full").status_code == 200
        assert client.post(f"/v1/worlds/{world_id}/tools/list_events", json={}).status_code == 200
    assert client.delete(f"/v1/worlds/{world_id}").status_code == 200
    for _ in range(6):
        assert client.get(f"/v1/worlds/{world_id}/rollouts/base?detail=full").status_code == 404
        assert client.post(f"/v1/worlds/{world_id}/tools/list_events", json={}).status_code == 404


def _children(pid: int) -> list[int]:
    """Pids whose parent is ``pid`` (from /proc, Linux)."""
    found = []
    for status in Path("/proc").glob("[0-9]*/status"):
        try:
            fields = dict(line.split(":\t", 1) for line in status.read_text().splitlines() if ":\t" in line)
        except OSError:
            continue
        if fields.get("PPid", "").strip() == str(pid):
            found.append(int(status.parent.name))
    return found


@pytest.mark.slow
def test_kill_9_of_the_server_leaves_no_worker_behind(tmp_path, server_factory):
    server = server_factory(tmp_path / "data", tmp_path / "server.log", {"PHYSMIND_WORKERS": "2"})
    with server.client() as http:
        assert http.get("/v1/worlds").status_code == 200
    deadline = time.monotonic() + 20
    while len(_children(server.process.pid)) < 2 and time.monotonic() < deadline:
        time.sleep(0.2)
    children = _children(server.process.pid)
    assert len(children) >= 2
    os.kill(server.process.pid, signal.SIGKILL)
    server.process.wait(10)
    deadline = time.monotonic() + 10
    while time.monotonic() < deadline and any(Path(f"/proc/{pid}").exists() for pid in children):
        time.sleep(0.2)
    assert not [pid for pid in children if Path(f"/proc/{pid}").exists()]
