"""The render endpoints and the viewer's static files, in process (FastAPI TestClient)."""

from __future__ import annotations

import io

import av
import pytest
from fastapi.testclient import TestClient
from PIL import Image

from server.app import create_app
from server.settings import Settings
from world.io import world_to_dict
from world.rollout import default_horizon


@pytest.fixture()
def client(tmp_path, monkeypatch):
    monkeypatch.setenv("PHYSMIND_MAX_RENDER_FRAMES", "200")
    with TestClient(create_app(Settings(data_dir=tmp_path)), base_url="http://localhost") as http:
        yield http


@pytest.fixture()
def world_id(client, seven_world):
    response = client.post("/v1/worlds", json={"world": world_to_dict(seven_world), "name": "seven"})
    assert response.status_code == 201, response.text
    return response.json()["world_id"]


def test_plot_png_of_base_and_edited_rollouts_cached(client, world_id):
    url = f"/v1/worlds/{world_id}/rollouts/base/plot.png"
    first = client.get(url)
    assert first.status_code == 200 and first.headers["content-type"] == "image/png"
    assert first.headers["x-render-cache"] == "miss"
    assert Image.open(io.BytesIO(first.content)).size == (480, 360 + 34 + 26)
    again = client.get(url)
    assert again.headers["x-render-cache"] == "hit" and again.content == first.content
    edited = client.post(f"/v1/worlds/{world_id}/tools/simulate_edit",
                         json={"edit_type": "remove_object", "object_id": 1, "trajectory_detail": "summary"}).json()["rollout_id"]
    pair = client.get(f"/v1/worlds/{world_id}/rollouts/{edited}/plot.png", params={"width": 320, "frame": 40})
    assert pair.status_code == 200
    assert Image.open(io.BytesIO(pair.content)).size == (640, 240 + 34 + 2 * 26)


def test_video_mp4_and_frame_limit(client, world_id, seven_world, monkeypatch, tmp_path_factory):
    response = client.get(f"/v1/worlds/{world_id}/rollouts/base/video.mp4")
    assert response.status_code == 200 and response.headers["content-type"] == "video/mp4"
    with av.open(io.BytesIO(response.content)) as container:
        frames = sum(1 for _ in container.decode(video=0))
    assert frames == default_horizon(seven_world)
    monkeypatch.setenv("PHYSMIND_MAX_RENDER_FRAMES", "150")  # below the 154-frame horizon
    # One server per data directory (it is locked): the limited server gets its own, with the same world.
    with TestClient(create_app(Settings(data_dir=tmp_path_factory.mktemp("limited"))), base_url="http://localhost") as limited_client:
        created = limited_client.post("/v1/worlds", json={"world": world_to_dict(seven_world), "name": "seven"})
        world_id = created.json()["world_id"]
        limited = limited_client.get(f"/v1/worlds/{world_id}/rollouts/base/video.mp4")
        assert limited.status_code == 422
        assert limited.json()["error"]["code"] == "limit_exceeded" and limited.json()["error"]["limit"] == 150
        assert limited_client.get(f"/v1/worlds/{world_id}/rollouts/base/plot.png").status_code == 200


def test_unknown_ids_and_bad_parameters_are_structured_errors(client, world_id):
    missing = client.get(f"/v1/worlds/{world_id}/rollouts/r-nope/plot.png")
    assert missing.status_code == 404 and missing.json()["error"]["code"] == "rollout_not_found"
    assert "base" in missing.json()["error"]["valid_ids"]
    assert client.get("/v1/worlds/w-nope/rollouts/base/video.mp4").json()["error"]["code"] == "world_not_found"
    too_wide = client.get(f"/v1/worlds/{world_id}/rollouts/base/plot.png", params={"width": 99999})
    assert too_wide.status_code == 422 and too_wide.json()["error"]["pointer"] == "/width"
    bad_reference = client.get(f"/v1/worlds/{world_id}/rollouts/base/plot.png", params={"reference": "r-x"})
    assert bad_reference.status_code == 404 and bad_reference.json()["error"]["pointer"] == "/reference"


def test_viewer_static_files_are_served(client):
    page = client.get("/viewer/")
    assert page.status_code == 200 and "text/html" in page.headers["content-type"]
    assert "viewer.js" in page.text
    assert client.get("/viewer/viewer.js").status_code == 200
    assert client.get("/viewer/nope.js").json()["error"]["code"] == "route_not_found"


def test_rollout_endpoints_point_to_their_pictures(client, world_id):
    edited = client.post(f"/v1/worlds/{world_id}/tools/simulate_edit",
                         json={"edit_type": "remove_object", "object_id": 1, "trajectory_detail": "summary"}).json()["rollout_id"]
    detail = client.get(f"/v1/worlds/{world_id}/rollouts/{edited}").json()
    listed = {row["rollout_id"]: row["links"] for row in client.get(f"/v1/worlds/{world_id}/rollouts").json()["rollouts"]}
    assert listed[edited] == detail["links"]
    for kind, url in detail["links"].items():
        response = client.get(url)
        assert response.status_code == 200, (kind, response.text[:200])
        assert response.headers["content-type"] == {"plot_png": "image/png", "video_mp4": "video/mp4"}[kind]
