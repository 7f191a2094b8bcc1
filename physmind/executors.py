"""Where parallel work runs: a local process pool by default, a Dask cluster with ``--dask``.

``open_executor(None, n)`` is a pool of ``n`` spawned processes, each of which
ends itself when this process dies (kill -9 leaves no orphans);
``open_executor("local", n)`` starts a Dask LocalCluster of ``n`` worker
processes; ``open_executor("tcp://scheduler:8786", n)`` connects to a running
Dask scheduler (its workers need this package installed: the functions travel
by reference). All three are ``concurrent.futures.Executor``s, so builds
(physmind/pipeline.py, POST /v1/builds) and ``physmind eval`` use them alike.
"""

from __future__ import annotations

import argparse
import multiprocessing
import os
from concurrent.futures import Executor, Future, ProcessPoolExecutor, as_completed
from typing import Any, Callable, Iterator, Sequence

from server.workers import start_parent_watch

DASK_LOCAL = "local"
DASK_SCHEMES = ("tcp://", "tls://", "ucx://", "inproc://")
DASK_CONNECT_TIMEOUT_S = 10


def add_dask_argument(parser: argparse.ArgumentParser, what: str) -> None:
    parser.add_argument("--dask", default=None, metavar="local|tcp://HOST:8786",
                        help=f"run {what} on Dask: 'local' starts a LocalCluster, tcp://HOST:PORT uses a running "
                             "scheduler (default: a local process pool)")


def check_dask_address(address: str) -> str:
    """``address`` if it is 'local' or a scheduler URL, else a one-line ValueError."""
    if address == DASK_LOCAL or (address.startswith(DASK_SCHEMES) and len(address) > address.index("//") + 2):
        return address
    raise ValueError(f"--dask: expected 'local' or a scheduler address such as tcp://scheduler:8786, got {address[:80]!r}")


def describe(address: str | None) -> str:
    """Where the work runs, for logs and job records."""
    return "local processes" if address is None else f"dask {address}"


def process_pool(workers: int) -> ProcessPoolExecutor:
    """``workers`` spawned processes that exit when this process dies."""
    # spawn, not fork: the server process has threads (and SQLite connections) a fork would copy.
    return ProcessPoolExecutor(max_workers=workers, mp_context=multiprocessing.get_context("spawn"),
                               initializer=start_parent_watch, initargs=(os.getpid(),))


class DaskExecutor(Executor):
    """A dask.distributed Client as an Executor; shutting it down closes the client (and its LocalCluster)."""

    def __init__(self, client: Any, cluster: Any = None) -> None:
        self.client = client
        self.cluster = cluster
        self._executor = client.get_executor(pure=False)

    def submit(self, fn: Callable, /, *args: Any, **kwargs: Any) -> Future:
        return self._executor.submit(fn, *args, **kwargs)

    def shutdown(self, wait: bool = True, *, cancel_futures: bool = False) -> None:
        self._executor.shutdown(wait=wait and not cancel_futures)
        self.client.close()
        if self.cluster is not None:
            self.cluster.close()


def dask_executor(address: str, workers: int) -> DaskExecutor:
    # Lazy: dask.distributed takes about a second to import and is only needed with --dask.
    from distributed import Client, LocalCluster

    if address == DASK_LOCAL:
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None)
        return DaskExecutor(Client(cluster), cluster)
    try:
        client = Client(address, timeout=f"{DASK_CONNECT_TIMEOUT_S}s")
    except (OSError, TimeoutError) as error:
        raise ValueError(f"--dask {address}: cannot reach the Dask scheduler ({' '.join(str(error).split())[:200]})") from None
    return DaskExecutor(client)


def open_executor(address: str | None, workers: int) -> Executor:
    """A local process pool (``address`` None) or a Dask executor (``--dask`` value); ``workers`` >= 1."""
    if workers < 1:
        raise ValueError(f"workers: expected >= 1, got {workers}")
    return process_pool(workers) if address is None else dask_executor(check_dask_address(address), workers)


def run_jobs(fn: Callable, jobs: Sequence[tuple], workers: int = 1,
             dask: str | None = None) -> Iterator[tuple[int, Any, Exception | None]]:
    """``(position in jobs, fn(*job) or None, the exception it raised or None)`` for every job, as each
    finishes: in this process when ``workers`` <= 1 and no ``dask`` address is given, else on
    ``open_executor(dask, workers)``. A failing job does not stop the others. The executor is opened
    here, before the first job, so a bad or unreachable ``dask`` address fails before any progress output."""
    if workers <= 1 and dask is None:
        return _run_here(fn, jobs)
    return _run_on(open_executor(dask, max(1, workers)), fn, jobs)


def _run_here(fn: Callable, jobs: Sequence[tuple]) -> Iterator[tuple[int, Any, Exception | None]]:
    for position, job in enumerate(jobs):
        try:
            yield position, fn(*job), None
        except Exception as error:  # reported to the caller with its job
            yield position, None, error


def _run_on(executor: Executor, fn: Callable, jobs: Sequence[tuple]) -> Iterator[tuple[int, Any, Exception | None]]:
    with executor:
        futures = {executor.submit(fn, *job): position for position, job in enumerate(jobs)}
        for future in as_completed(futures):
            try:
                yield futures[future], future.result(), None
            except Exception as error:
                yield futures[future], None, error
