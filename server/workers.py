"""The worker pool: tool calls, world creation and rollout reads run here, off the event loop.

With ``settings.workers > 0`` they run in that many processes (spawned, each
with its own SqliteStore on the same WAL database), so CPU-heavy simulations
never hold the server's GIL and /healthz answers in milliseconds. With
``workers == 0`` they run in the event loop's thread pool (for embedding and
in-process tests).

Every call returns its response already encoded (bytes), so the event loop
only moves bytes. Bounded: at most ``max_pending`` calls queued or running
(more answer 429 with Retry-After), each answered within
``request_timeout_s`` (else 503 with Retry-After; the call itself finishes
in the background and keeps its slot until then), and an encoded response
above ``max_response_bytes`` answers 422 ``response_too_large``.
"""

from __future__ import annotations

import asyncio
import dataclasses
import multiprocessing
import os
import threading
import time
from concurrent.futures import Executor, ProcessPoolExecutor, ThreadPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from typing import Any

from server.errors import json_bytes
from server.settings import Settings
from server.store import SqliteStore
from server.world_registry import WorldRegistry
from tools.errors import ToolError

RETRY_AFTER_S = 1.0
Outcome = tuple[str, Any]  # ("ok", encoded bytes) or ("error", ToolError fields)

_WORKER_REGISTRY: WorldRegistry | None = None


# -- inside a worker -----------------------------------------------------------------
WORKER_NICENESS = 10
ORPHAN_CHECK_S = 1.0


def _init_worker(settings: Settings, server_pid: int) -> None:
    global _WORKER_REGISTRY
    # Below the event loop's priority: under load the server still accepts, routes and answers /healthz.
    os.nice(WORKER_NICENESS)
    start_parent_watch(server_pid)
    _WORKER_REGISTRY = WorldRegistry(SqliteStore(settings.database_path), settings)


def start_parent_watch(parent_pid: int) -> None:
    """In a worker process: exit as soon as ``parent_pid`` is no longer its parent.

    A kill -9 of the server runs no clean-up, so its workers would live on
    (orphans holding the database and the CPU); each one watches its parent
    instead, on a daemon thread, and ends itself within ORPHAN_CHECK_S.
    """
    threading.Thread(target=_exit_when_orphaned, args=(parent_pid,), daemon=True, name="physmind-orphan-watch").start()


def _exit_when_orphaned(parent_pid: int) -> None:
    while os.getppid() == parent_pid:
        time.sleep(ORPHAN_CHECK_S)
    os._exit(0)


def _encode(result: Any, limit: int) -> bytes:
    body = json_bytes(result)
    if len(body) > limit:
        raise ToolError(code="response_too_large", tool=None, pointer="", status=422,
                        message=f"the response would be {len(body)} bytes, above this server's limit of {limit} "
                                "(PHYSMIND_MAX_RESPONSE_BYTES); ask for trajectory_detail 'summary' or 'sampled' "
                                "with a larger sample_every, a frame range, or detail=summary",
                        expected=f"a response of at most {limit} bytes", extra={"limit": limit})
    return body


def execute(registry: WorldRegistry, method: str, args: tuple) -> Outcome:
    """Run ``registry.<method>(*args)`` and encode its answer; a ToolError travels back as its fields."""
    try:
        result = getattr(registry, method)(*args)
        return "ok", _encode(result, registry.settings.max_response_bytes)
    except ToolError as error:
        return "error", dataclasses.asdict(error)


def _execute_in_worker(method: str, args: tuple) -> Outcome:
    assert _WORKER_REGISTRY is not None, "worker not initialised"
    return execute(_WORKER_REGISTRY, method, args)


def _warm() -> bool:
    return _WORKER_REGISTRY is not None


# -- in the server -------------------------------------------------------------------
def busy_error(message: str, status: int) -> ToolError:
    return ToolError(code="busy" if status == 429 else "unavailable", tool=None, pointer="", status=status,
                     message=message, expected=f"retry after {RETRY_AFTER_S:g} s",
                     extra={"retry_after_s": RETRY_AFTER_S})


class WorkerPool:
    """Runs WorldRegistry methods in worker processes (or threads), bounded in count and time."""

    def __init__(self, settings: Settings, registry: WorldRegistry) -> None:
        self.settings = settings
        self.registry = registry  # used directly in thread mode
        self._pending = 0
        self._lock = threading.Lock()
        self._executor: Executor = self._new_executor()

    def _new_executor(self) -> Executor:
        if self.settings.workers == 0:
            return ThreadPoolExecutor(max_workers=4, thread_name_prefix="physmind-call")
        # spawn, not fork: the server process has threads (and SQLite connections) a fork would copy.
        return ProcessPoolExecutor(max_workers=self.settings.workers, mp_context=multiprocessing.get_context("spawn"),
                                   initializer=_init_worker, initargs=(self.settings, os.getpid()))

    def warm_up(self) -> None:
        """Start the worker processes now rather than on the first call."""
        if isinstance(self._executor, ProcessPoolExecutor):
            for _ in range(self.settings.workers):
                self._executor.submit(_warm)

    def shutdown(self) -> None:
        self._executor.shutdown(wait=False, cancel_futures=True)

    def _release(self, _: Any) -> None:
        with self._lock:
            self._pending -= 1

    async def call(self, method: str, *args: Any) -> bytes:
        """The encoded result of ``WorldRegistry.<method>(*args)``; raises ToolError."""
        with self._lock:
            if self._pending >= self.settings.max_pending:
                raise busy_error(f"{self._pending} calls are already queued or running, the limit of this server "
                                 f"(PHYSMIND_MAX_PENDING={self.settings.max_pending}); retry shortly", 429)
            self._pending += 1
        try:
            if isinstance(self._executor, ProcessPoolExecutor):
                future = self._executor.submit(_execute_in_worker, method, args)
            else:
                future = self._executor.submit(execute, self.registry, method, args)
        except BrokenProcessPool:
            self._release(None)
            self._restart()
            raise busy_error("the worker pool was restarted after a worker died; retry shortly", 503) from None
        future.add_done_callback(self._release)
        try:
            kind, value = await asyncio.wait_for(asyncio.shield(asyncio.wrap_future(future)), self.settings.request_timeout_s)
        except asyncio.TimeoutError:
            raise busy_error(f"the call did not finish within {self.settings.request_timeout_s} s "
                             "(PHYSMIND_REQUEST_TIMEOUT_S); the server is overloaded or the request is too large", 503) from None
        except BrokenProcessPool:
            self._restart()
            raise busy_error("a worker process died during the call (out of memory?); the pool was restarted", 503) from None
        if kind == "error":
            raise ToolError(**value)
        return value

    def _restart(self) -> None:
        with self._lock:
            old, self._executor = self._executor, self._new_executor()
        old.shutdown(wait=False, cancel_futures=True)
