"""POST /v1/builds: a world built from an uploaded video (tests/data/synth), its job status, and every refusal."""

from __future__ import annotations

import json
import os
import signal
import time
from pathlib import Path

import jsonschema
import pytest

from bench.proc_tree import descendants, is_alive
from schemas import read_schema
from server.builds import BuildJobs
from server.contract import response_schema
from server.settings import Settings
from server.store import SqliteStore

FIXTURES = Path(__file__).resolve().parents[1] / "data" / "synth"
VIDEO = FIXTURES / "videos" / "video_00001.mp4"
CAMERA = FIXTURES / "ground_truth" / "scene_00001.json"
ERROR_SCHEMA = read_schema("error.schema.json")
BUILD_TIMEOUT_S = 240


def _upload(http, video: bytes, camera: str | bytes, **fields):
    files = {"video": ("video.mp4", video, "video/mp4"), "camera": ("camera.json", camera, "application/json")}
    return http.post("/v1/builds", files=files, data=fields)


def _error(response, status: int, code: str) -> dict:
    assert response.status_code == status, response.text
    body = response.json()
    jsonschema.validate(body, ERROR_SCHEMA)
    assert body["error"]["code"] == code, body
    return body["error"]


def _wait(http, build_id: str, timeout: float = BUILD_TIMEOUT_S) -> dict:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        status = http.get(f"/v1/builds/{build_id}")
        assert status.status_code == 200, status.text
        record = status.json()
        jsonschema.validate(record, response_schema("build_status"))
        if record["state"] in ("done", "failed"):
            return record
        time.sleep(0.5)
    raise AssertionError(f"build {build_id} did not finish within {timeout} s")


@pytest.mark.slow
def test_video_upload_builds_and_registers_a_world(client):
    response = _upload(client, VIDEO.read_bytes(), CAMERA.read_text(), name="scene 1")
    assert response.status_code == 202, response.text
    accepted = response.json()
    jsonschema.validate(accepted, response_schema("build_status"))
    assert accepted["state"] == "queued" and response.headers["location"] == f"/v1/builds/{accepted['build_id']}"
    record = _wait(client, accepted["build_id"])
    assert record["state"] == "done", record["error"]
    assert record["progress"] == 1.0 and record["info"]["perception_seconds"] > 0
    world = client.get(f"/v1/worlds/{record['world_id']}")
    assert world.status_code == 200
    assert world.json()["name"] == "scene 1"
    # as many bodies as MuJoCo's scene had objects (the generator's ground truth)
    truth = json.loads(CAMERA.read_text())
    assert world.json()["object_count"] == len(truth["objects"])
    listed = client.get("/v1/builds").json()["builds"]
    assert record["build_id"] in [b["build_id"] for b in listed]


def test_unreadable_video_fails_the_job_cleanly_and_stores_no_world(client):
    worlds_before = {w["world_id"] for w in client.get("/v1/worlds").json()["worlds"]}
    response = _upload(client, os.urandom(4096), CAMERA.read_text())
    assert response.status_code == 202, response.text
    record = _wait(client, response.json()["build_id"], timeout=120)
    assert record["state"] == "failed" and record["world_id"] is None
    assert record["error"]["code"] == "invalid_video"
    assert "uploaded video" in record["error"]["message"] and "/tmp/" not in record["error"]["message"]
    assert {w["world_id"] for w in client.get("/v1/worlds").json()["worlds"]} == worlds_before


@pytest.mark.parametrize("camera, pointer, code", [
    ("not json", "/camera", "invalid_json"),
    ('{"width": 480}', "/camera", "invalid_arguments"),
    ('[1, 2]', "/camera", "invalid_arguments"),
])
def test_bad_camera_is_refused_before_any_job(client, camera, pointer, code):
    builds_before = len(client.get("/v1/builds").json()["builds"])
    error = _error(_upload(client, VIDEO.read_bytes(), camera), 422, code)
    assert error["pointer"] == pointer
    assert len(client.get("/v1/builds").json()["builds"]) == builds_before


def test_form_refusals(client):
    camera = CAMERA.read_text()
    assert _error(_upload(client, b"", camera), 422, "invalid_arguments")["pointer"] == "/video"
    missing = client.post("/v1/builds", files={"camera": ("camera.json", camera, "application/json")})
    assert _error(missing, 422, "invalid_arguments")["pointer"] == "/video"
    as_text = client.post("/v1/builds", data={"video": "abc"}, files={"camera": ("camera.json", camera, "application/json")})
    assert _error(as_text, 422, "invalid_arguments")["pointer"] == "/video"
    _error(client.post("/v1/builds", data={"video": "abc", "camera": camera}), 415, "unsupported_media_type")  # url-encoded
    extra = _upload(client, b"x", camera, colour="red")
    assert _error(extra, 422, "invalid_arguments")["pointer"] == "/colour"
    assert _error(_upload(client, b"x", camera, name="n" * 201), 422, "invalid_arguments")["pointer"] == "/name"
    _error(client.post("/v1/builds", json={"video": "x"}), 415, "unsupported_media_type")
    cross_site = client.post("/v1/builds", files={"video": ("v.mp4", b"x")}, headers={"Origin": "http://evil.example"})
    _error(cross_site, 403, "forbidden_origin")
    broken = client.post("/v1/builds", content=b"--zz\r\nnot a part", headers={"Content-Type": "multipart/form-data; boundary=zz"})
    assert broken.status_code in (415, 422) and "error" in broken.json()


def test_unknown_build_id(client):
    error = _error(client.get("/v1/builds/b-" + "0" * 16), 404, "build_not_found")
    assert "b-0000" in error["message"]
    long_id = client.get("/v1/builds/" + "x" * 5000)
    assert len(_error(long_id, 404, "build_not_found")["message"]) < 400


def test_upload_limit_and_build_cap(tmp_path, server_factory):
    limit = VIDEO.stat().st_size + CAMERA.stat().st_size + 4096  # the fixture's upload fits, with room for the form
    server = server_factory(tmp_path / "data", tmp_path / "server.log",
                            {"PHYSMIND_MAX_UPLOAD_BYTES": str(limit), "PHYSMIND_MAX_BUILDS": "1",
                             "PHYSMIND_BUILD_TIMEOUT_S": "1", "PHYSMIND_WORKERS": "0"})
    try:
        with server.client() as http:
            too_large = _upload(http, os.urandom(limit), CAMERA.read_text())
            assert _error(too_large, 413, "payload_too_large")["limit"] == limit
            first = _upload(http, VIDEO.read_bytes(), CAMERA.read_text())
            assert first.status_code == 202, first.text
            busy = _upload(http, VIDEO.read_bytes(), CAMERA.read_text())
            _error(busy, 429, "busy")
            assert float(busy.headers["retry-after"]) > 0
            record = _wait(http, first.json()["build_id"], timeout=30)
            assert record["state"] == "failed" and record["error"]["code"] == "build_timeout"
            assert "PHYSMIND_BUILD_TIMEOUT_S" in record["error"]["message"]
    finally:
        server.stop()


def test_jobs_a_stopped_server_left_unfinished_are_failed_on_start(tmp_path):
    settings = Settings(data_dir=tmp_path, workers=0)
    store = SqliteStore(settings.database_path)
    for state in ("queued", "running", "registering", "done"):
        store.put_build(f"b-{state}", 1.0, {"build_id": f"b-{state}", "state": state, "created_at": 1.0,
                                            "error": None, "world_id": "w-1" if state == "done" else None})
    BuildJobs(settings, store, pool=None, backend=None).start()  # type: ignore[arg-type]
    states = {r["build_id"]: (r["state"], (r["error"] or {}).get("code")) for r in store.list_builds()}
    assert states == {"b-queued": ("failed", "server_restarted"), "b-running": ("failed", "server_restarted"),
                      "b-registering": ("failed", "server_restarted"), "b-done": ("done", None)}
    store.close()


def _kill_9_during_a_build(tmp_path, server_factory, extra_args: tuple[str, ...], expected_processes: int,
                           check_restart: bool) -> None:
    # a generous start-up time: a LocalCluster starts its worker processes before the server answers
    server = server_factory(tmp_path / "data", tmp_path / "server.log", {"PHYSMIND_WORKERS": "1"}, timeout=180,
                            extra_args=extra_args)
    with server.client() as http:
        accepted = _upload(http, VIDEO.read_bytes(), CAMERA.read_text())
        assert accepted.status_code == 202, accepted.text
        build_id = accepted.json()["build_id"]
    deadline = time.monotonic() + 60
    while len(descendants(server.process.pid)) < expected_processes and time.monotonic() < deadline:
        time.sleep(0.2)
    processes = descendants(server.process.pid)
    assert len(processes) >= expected_processes, processes
    os.kill(server.process.pid, signal.SIGKILL)
    server.process.wait(10)
    deadline = time.monotonic() + 15
    while time.monotonic() < deadline and any(is_alive(pid) for pid in processes):
        time.sleep(0.2)
    assert not [pid for pid in processes if is_alive(pid)], "processes outlived the killed server"
    if not check_restart:
        return
    # the job the dead server was running is reported, not lost
    restarted = server_factory(tmp_path / "data", tmp_path / "server2.log", {"PHYSMIND_WORKERS": "0"})
    try:
        with restarted.client() as http:
            record = http.get(f"/v1/builds/{build_id}").json()
        assert record["state"] == "failed" and record["error"]["code"] == "server_restarted"
    finally:
        restarted.stop()


@pytest.mark.slow
def test_kill_9_during_a_build_leaves_no_process_and_fails_the_job(tmp_path, server_factory):
    # a tool worker and a build worker (plus multiprocessing's resource tracker)
    _kill_9_during_a_build(tmp_path, server_factory, (), expected_processes=2, check_restart=True)


@pytest.mark.slow
def test_kill_9_with_a_dask_local_cluster_leaves_no_process(tmp_path, server_factory):
    # a tool worker, the LocalCluster's nanny and its worker
    _kill_9_during_a_build(tmp_path, server_factory, ("--dask", "local"), expected_processes=3, check_restart=False)
