"""SqliteStore: persistence across instances, thread safety, cascading delete."""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest

from server.settings import Settings
from server.store import SqliteStore, WorldGone
from tools.session import WorldSession, new_rollout_id
from world.io import world_to_dict
from world.rollout import simulate
from world.types import Edit


@pytest.fixture()
def world(scene_builders):
    return scene_builders.six_object_world()


def test_worlds_and_rollouts_survive_a_new_store_instance(tmp_path, world):
    path = tmp_path / "db.sqlite3"
    first = SqliteStore(path)
    base = simulate(world)
    first.create_world("w-1", world, world_to_dict(world), base, name="one")
    edited = simulate(world, [Edit("remove_object", 2)], rollout_id="r-1")
    first.put_rollout("w-1", edited, "base")
    first.close()

    second = SqliteStore(path)
    assert [w.world_id for w in second.list_worlds()] == ["w-1"]
    assert second.world_row("w-1").rollout_count == 2 and second.world_row("w-1").name == "one"
    assert second.get_world("w-1") == world
    loaded = second.get_rollout("w-1", "r-1")
    np.testing.assert_array_equal(loaded.positions, edited.positions)
    assert loaded.events == edited.events and loaded.edits == edited.edits
    assert second.rollout_ids("w-1") == ["base", "r-1"]
    assert second.get_rollout("w-1", "r-404") is None and second.get_world("w-404") is None
    second.close()


def test_delete_cascades_and_late_writes_fail_cleanly(tmp_path, world):
    store = SqliteStore(tmp_path / "db.sqlite3")
    store.create_world("w-1", world, world_to_dict(world), simulate(world))
    assert store.delete_world("w-1") is True and store.delete_world("w-1") is False
    assert store.rollout_ids("w-1") == [] and store.get_rollout("w-1", "base") is None
    with pytest.raises(WorldGone):
        store.put_rollout("w-1", simulate(world, rollout_id="r-late"), "base")
    store.close()


def test_many_threads_writing_and_reading(tmp_path, world):
    store = SqliteStore(tmp_path / "db.sqlite3", cache_size=4)  # tiny cache: reads hit SQLite
    store.create_world("w-1", world, world_to_dict(world), simulate(world))
    session = WorldSession("w-1", world, store)

    def work(index: int) -> str:
        rollout = session.create_rollout([Edit("remove_object", index % 6)], None, "base")
        assert store.get_rollout("w-1", rollout.id).body_ids == rollout.body_ids
        return rollout.id

    with ThreadPoolExecutor(16) as pool:
        ids = list(pool.map(work, range(48)))
    assert len(set(ids)) == 48
    assert sorted(store.rollout_ids("w-1")) == sorted(["base", *ids])
    store.close()


def test_rollout_ids_are_unique_strings():
    ids = {new_rollout_id() for _ in range(10000)}
    assert len(ids) == 10000 and all(i.startswith("r-") for i in ids)


@pytest.mark.parametrize(
    "env, field, value",
    [
        ({}, "max_request_bytes", 4 * 1024 * 1024),
        ({"PHYSMIND_MAX_REQUEST_BYTES": "1000"}, "max_request_bytes", 1000),
        ({"PHYSMIND_MAX_HORIZON_FRAMES": "99"}, "max_horizon_frames", 99),
        ({"PHYSMIND_API_KEY": "k"}, "api_key", "k"),
        ({"PHYSMIND_API_KEY": ""}, "api_key", None),
        ({"PHYSMIND_VALIDATE_RESULTS": "0"}, "validate_results", False),
        ({"PHYSMIND_DATA_DIR": "/tmp/x"}, "database_path", __import__("pathlib").Path("/tmp/x/physmind.sqlite3")),
    ],
)
def test_settings_from_env(env, field, value):
    assert getattr(Settings.from_env(env), field) == value


@pytest.mark.parametrize("env", [{"PHYSMIND_MAX_REQUEST_BYTES": "lots"}, {"PHYSMIND_MAX_HORIZON_FRAMES": "0"}])
def test_bad_settings_name_the_variable(env):
    with pytest.raises(ValueError, match=next(iter(env))):
        Settings.from_env(env)
