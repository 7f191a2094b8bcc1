from __future__ import annotations

import pytest

from scene_builders import six_object_world
from tools.session import MemoryRolloutStore, WorldSession


@pytest.fixture(scope="module")
def world():
    return six_object_world()


@pytest.fixture()
def session(world):
    """A fresh in-memory session on the six-object world (base computed lazily)."""
    return WorldSession("w-test", world, MemoryRolloutStore())
