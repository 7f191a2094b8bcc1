"""Where builds and evaluations run: the local process pool and Dask (a LocalCluster, started in about a second)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from physmind.executors import DaskExecutor, check_dask_address, open_executor
from physmind.pipeline import build_worlds
from planner.evaluate import load_dataset

FIXTURES = Path(__file__).resolve().parent / "data" / "synth"


def _pid(_: int) -> int:
    return os.getpid()


def test_dask_address_is_checked():
    assert check_dask_address("local") == "local"
    assert check_dask_address("tcp://scheduler:8786") == "tcp://scheduler:8786"
    for bad in ("", "scheduler:8786", "http://x:8786", "tcp://"):
        with pytest.raises(ValueError, match="--dask"):
            check_dask_address(bad)


def test_unreachable_scheduler_is_one_line_error():
    with pytest.raises(ValueError, match="cannot reach the Dask scheduler"):
        open_executor("tcp://127.0.0.1:1", 1)


def test_local_pool_runs_in_other_processes():
    with open_executor(None, 2) as executor:
        pids = set(executor.map(_pid, range(4)))
    assert os.getpid() not in pids


@pytest.mark.slow
def test_dask_local_cluster_builds_the_same_world_as_serial():
    entries = [e for e in load_dataset(FIXTURES) if e.scene_index == 1]
    serial_worlds, serial_infos = build_worlds(entries, "annotation", progress=False)
    executor = open_executor("local", 1)
    try:
        assert isinstance(executor, DaskExecutor)
        workers = executor.client.scheduler_info()["workers"]
        assert len(workers) == 1
        assert executor.submit(_pid, 0).result(timeout=60) != os.getpid()  # a worker process, not this one
    finally:
        executor.shutdown()
    dask_worlds, dask_infos = build_worlds(entries, "annotation", workers=1, progress=False, dask="local")
    assert "error" not in dask_infos[1], dask_infos[1]
    assert _without_timings(dask_worlds[1]) == _without_timings(serial_worlds[1])


def _without_timings(document: dict) -> dict:
    """The world document minus the fit's wall and CPU times (the only fields that differ between runs)."""
    fit = {k: v for k, v in document["provenance"]["fit"].items() if k not in ("seconds", "cpu_seconds")}
    return {**document, "provenance": {**document["provenance"], "fit": fit}}
