"""Bounded cost: budget per request, response cap, pending-call cap, storage quota, upload and call timeouts."""

from __future__ import annotations

import socket
import threading
import time
from urllib.parse import urlparse

import jsonschema
import pytest
from fastapi.testclient import TestClient

from schemas import read_schema
from server.app import create_app
from server.settings import Settings
from tools.errors import ToolError


def make_client(tmp_path, **overrides) -> TestClient:
    settings = Settings(data_dir=tmp_path / "data", workers=0, log_level="WARNING", **overrides)
    return TestClient(create_app(settings), base_url="http://localhost")


def envelope(response, status: int, code: str) -> dict:
    assert response.status_code == status, response.text
    jsonschema.validate(response.json(), read_schema("error.schema.json"))
    assert response.json()["error"]["code"] == code
    return response.json()["error"]


def test_cost_budget_names_the_budget_on_tools_and_on_create(tmp_path, world_document):
    with make_client(tmp_path, max_cost=6 * 400) as http:
        world_id = http.post("/v1/worlds", json={"world": world_document}).json()["world_id"]
        ok = http.post(f"/v1/worlds/{world_id}/tools/simulate_edit",
                       json={"edit_type": "remove_object", "object_id": 1, "horizon_frames": 400, "trajectory_detail": "summary"})
        assert ok.status_code == 200, ok.text
        error = envelope(http.post(f"/v1/worlds/{world_id}/tools/simulate_edit",
                                   json={"edit_type": "remove_object", "object_id": 1, "horizon_frames": 400,
                                         "trajectory_detail": "full"}), 422, "cost_exceeded")
        assert error["limit"] == 2400 and "2400" in error["message"] and "4800" in error["message"]
        assert error["tool"] == "simulate_edit"
        before = len(http.get(f"/v1/worlds/{world_id}/rollouts").json()["rollouts"])
        envelope(http.post("/v1/worlds", json={"world": world_document, "horizon_frames": 401}), 422, "cost_exceeded")
        assert len(http.get("/v1/worlds").json()["worlds"]) == 1
        assert len(http.get(f"/v1/worlds/{world_id}/rollouts").json()["rollouts"]) == before


def test_response_cap_answers_422_and_suggests_lighter_detail(tmp_path, world_document):
    with make_client(tmp_path, max_response_bytes=20_000) as http:
        world_id = http.post("/v1/worlds", json={"world": world_document}).json()["world_id"]
        error = envelope(http.post(f"/v1/worlds/{world_id}/tools/simulate_edit",
                                   json={"edit_type": "remove_object", "object_id": 1, "trajectory_detail": "full"}),
                         422, "response_too_large")
        assert error["limit"] == 20_000 and "summary" in error["message"]
        envelope(http.get(f"/v1/worlds/{world_id}/rollouts/base?detail=full"), 422, "response_too_large")
        assert http.get(f"/v1/worlds/{world_id}/rollouts/base").status_code == 200


def test_storage_quota_answers_507_before_storing(tmp_path, world_document):
    with make_client(tmp_path, max_storage_bytes=1) as http:
        envelope(http.post("/v1/worlds", json={"world": world_document}), 507, "storage_quota_exceeded")
        assert http.get("/v1/worlds").json()["worlds"] == []


def test_pending_cap_answers_429_with_retry_after(tmp_path, world_document, monkeypatch):
    with make_client(tmp_path, max_pending=1) as http:
        world_id = http.post("/v1/worlds", json={"world": world_document}).json()["world_id"]
        registry = http.app.state.registry
        release = threading.Event()
        original = registry.run_tool

        def slow_run_tool(*args):
            release.wait(10)
            return original(*args)

        monkeypatch.setattr(registry, "run_tool", slow_run_tool)
        first: dict = {}
        thread = threading.Thread(target=lambda: first.update(r=http.post(f"/v1/worlds/{world_id}/tools/list_events", json={})))
        thread.start()
        deadline = time.monotonic() + 10
        while http.app.state.pool._pending < 1 and time.monotonic() < deadline:
            time.sleep(0.01)
        busy = http.post(f"/v1/worlds/{world_id}/tools/list_events", json={})
        assert http.get("/healthz").status_code == 200  # cheap routes do not queue behind the pool
        release.set()
        thread.join(10)
        error = envelope(busy, 429, "busy")
        assert int(busy.headers["retry-after"]) >= 1 and error["retry_after_s"] > 0
        assert first["r"].status_code == 200


def test_call_timeout_answers_503_with_retry_after(tmp_path, world_document, monkeypatch):
    with make_client(tmp_path, request_timeout_s=1) as http:
        world_id = http.post("/v1/worlds", json={"world": world_document}).json()["world_id"]
        registry = http.app.state.registry
        original = registry.run_tool
        monkeypatch.setattr(registry, "run_tool", lambda *args: (time.sleep(2.5), original(*args))[1])
        response = http.post(f"/v1/worlds/{world_id}/tools/list_events", json={})
        envelope(response, 503, "unavailable")
        assert "retry-after" in response.headers


@pytest.mark.slow
def test_stalled_uploads_are_cut_off_and_healthz_stays_fast(tmp_path, server_factory):
    server = server_factory(tmp_path / "data", tmp_path / "server.log", {"PHYSMIND_BODY_TIMEOUT_S": "1"})
    try:
        url = urlparse(server.url)
        stalled = []
        for _ in range(20):
            sock = socket.create_connection((url.hostname, url.port), timeout=5)
            sock.sendall(b"POST /v1/worlds HTTP/1.1\r\nHost: localhost\r\nContent-Type: application/json\r\n"
                         b"Content-Length: 1000\r\n\r\n{\"world\":")
            stalled.append(sock)
        started = time.perf_counter()
        assert server.client().get("/healthz").status_code == 200
        assert time.perf_counter() - started < 2.0
        answers = []
        for sock in stalled:
            sock.settimeout(10)
            data = sock.recv(65536)
            answers.append(data.split(b"\r\n", 1)[0])
            sock.close()
        assert all(b" 408 " in a for a in answers), answers[:3]
    finally:
        server.stop()


def test_worker_errors_travel_back_as_tool_errors():
    from server.workers import execute

    class Registry:
        settings = Settings(max_response_bytes=100)

        def boom(self):
            raise ToolError(code="invalid_arguments", message="m", tool="t", pointer="/x", expected="e", status=422)

        def big(self):
            return {"x": "y" * 1000}

    kind, fields = execute(Registry(), "boom", ())
    assert kind == "error" and ToolError(**fields).pointer == "/x"
    kind, fields = execute(Registry(), "big", ())
    assert kind == "error" and fields["code"] == "response_too_large"
