"""Shared fixtures of the planner tests: one tool server per session, hand-made worlds, fitted fixture worlds."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from physmind.local_server import local_server
from physmind.pipeline import build_worlds
from planner.client import ToolClient
from planner.evaluate import load_dataset
from world.io import world_to_dict

REPO = Path(__file__).resolve().parents[2]
FIXTURES = REPO / "tests" / "data" / "synth"
# The first four fixture scenes (by index, not by accuracy) are fitted once per session
# for the accuracy and command tests (fit time depends on the identification version).
FITTED_SCENES = (0, 1, 2, 3)


@pytest.fixture(scope="session")
def six_world(scene_builders):
    """Chain 0->1->2->3, sphere 4 enters at t=1 s and hits 3, sphere 5 leaves the view (tests/tools/scene_builders.py)."""
    return scene_builders.six_object_world()


@pytest.fixture(scope="session")
def six_document(six_world) -> dict:
    return world_to_dict(six_world)


@pytest.fixture(scope="session")
def server_url(tmp_path_factory):
    with local_server(tmp_path_factory.mktemp("planner-server")) as url:
        yield url


@pytest.fixture()
def tool_client(server_url):
    with ToolClient(server_url) as client:
        yield client


@pytest.fixture(scope="session")
def fitted_fixture_worlds(tmp_path_factory):
    """(entries, worlds, build infos, cache dir) for FITTED_SCENES, built with the eval code path (2 processes)."""
    entries = [e for e in load_dataset(FIXTURES) if e.scene_index in FITTED_SCENES]
    cache = tmp_path_factory.mktemp("fitted-worlds")
    worlds, infos = build_worlds(entries, "annotation", workers=2, cache_dir=cache, progress=False)
    return entries, worlds, infos, cache


@pytest.fixture(scope="session")
def fixture_questions() -> dict[int, dict]:
    return {v["scene_index"]: v for v in json.loads((FIXTURES / "questions.json").read_text())}
