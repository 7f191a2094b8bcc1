"""Fixtures shared across test folders."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]


def load_scene_builders():
    """tests/tools/scene_builders.py, loaded by path (the test folders are not packages)."""
    spec = importlib.util.spec_from_file_location("scene_builders_shared", REPO / "tests" / "tools" / "scene_builders.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="session")
def scene_builders():
    """The hand-made worlds of tests/tools/scene_builders.py (six-object world, ...)."""
    return load_scene_builders()
