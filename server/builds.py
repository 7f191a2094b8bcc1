"""Build jobs: a world built from an uploaded video, off the event loop, bounded in count and time.

The server knows nothing of perception or identification: the composition
root (physmind/) hands it a ``BuildBackend``, a picklable build function and
the executor it runs on (a local process pool, or a Dask cluster). A job is

    queued -> running -> registering -> done (world_id)
                                     \\-> failed (error envelope fields)

and every state change is written to SQLite, so ``GET /v1/builds/{id}``
answers from any process and a restart turns the jobs it interrupted into
``failed`` (``server_restarted``), never loses them silently.
"""

from __future__ import annotations

import asyncio
import json
import time
import uuid
from concurrent.futures import Executor, Future
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass
from typing import Any, Callable

from server.settings import Settings
from server.store import SqliteStore
from server.workers import WorkerPool, busy_error
from tools.errors import ToolError, not_found

# (video bytes, camera document) -> {"world": world document, "info": {...build timings...}}.
# Raises ValueError (or OSError) with a one-line message for an input it cannot build from.
BuildFunction = Callable[[bytes, dict], dict]

STATES = ("queued", "running", "registering", "done", "failed")
FINISHED = ("done", "failed")
PROGRESS = {"queued": 0.0, "running": 0.1, "registering": 0.9, "done": 1.0, "failed": 1.0}
POLL_S = 0.25
MESSAGE_CHARS = 500


@dataclass(frozen=True)
class BuildBackend:
    """What the composition root gives the server to build worlds with.

    build: top-level (picklable) BuildFunction; open_executor: makes the
    Executor the builds run on from a worker count (PHYSMIND_BUILD_WORKERS;
    called once, at startup); where: a short description for the log and the
    job records ("local processes", "dask tcp://scheduler:8786").
    """

    build: BuildFunction
    open_executor: Callable[[int], Executor]
    where: str


def _failure(code: str, message: str, expected: str | None = None) -> dict:
    return {"code": code, "tool": None, "pointer": "", "message": " ".join(str(message).split())[:MESSAGE_CHARS] or code,
            "expected": expected}


def _build_error(error: BaseException) -> dict:
    """The job's error fields for an exception raised by the build function."""
    if isinstance(error, (ValueError, OSError)):
        return _failure("invalid_video", str(error), "a readable video (mp4, h264) of the scene and its camera")
    if isinstance(error, BrokenProcessPool):
        return _failure("build_failed", "the build process died (out of memory?)")
    return _failure("build_failed", f"{type(error).__name__}: {error}")


class BuildJobs:
    """Starts build jobs, follows them, and registers their worlds through the worker pool."""

    def __init__(self, settings: Settings, store: SqliteStore, pool: WorkerPool, backend: BuildBackend | None) -> None:
        self.settings = settings
        self.store = store
        self.pool = pool
        self.backend = backend
        self._executor: Executor | None = None
        self._running: set[Future] = set()  # futures still occupying the executor (timed-out ones too)
        self._tasks: set[asyncio.Task] = set()

    # -- lifecycle ------------------------------------------------------------------
    def start(self) -> None:
        """Fail the jobs a previous run left unfinished, then open the executor."""
        for record in self.store.list_builds():
            if record["state"] not in FINISHED:
                self._save({**record, "state": "failed", "progress": PROGRESS["failed"], "finished_at": time.time(),
                            "error": _failure("server_restarted", "the server stopped before this build finished; "
                                              "submit the video again")})
        if self.backend is not None:
            self._executor = self.backend.open_executor(self.settings.build_workers)

    def shutdown(self) -> None:
        for task in list(self._tasks):
            task.cancel()
        if self._executor is not None:
            self._executor.shutdown(wait=False, cancel_futures=True)

    # -- records --------------------------------------------------------------------
    def _save(self, record: dict) -> dict:
        self.store.put_build(record["build_id"], record["created_at"], record)
        return record

    def status(self, build_id: str) -> dict:
        record = self.store.get_build(build_id)
        if record is None:
            raise not_found("build", build_id, self.store.build_ids(), tool=None, pointer="")
        return record

    def records(self) -> list[dict]:
        return self.store.list_builds()

    # -- jobs -----------------------------------------------------------------------
    def submit(self, video: bytes, camera: dict, name: str | None) -> dict:
        """Queue a build (called on the event loop); 503 without a backend, 429 at the cap."""
        if self.backend is None or self._executor is None:
            raise ToolError(code="builds_unavailable", tool=None, pointer="", status=503,
                            message="this server was started without a build backend; start it with `physmind serve`",
                            expected=None)
        self._running = {f for f in self._running if not f.done()}
        if len(self._running) >= self.settings.max_builds:
            raise busy_error(f"{len(self._running)} builds are already queued or running, the limit of this server "
                             f"(PHYSMIND_MAX_BUILDS={self.settings.max_builds}); retry later", 429)
        now = time.time()
        record = self._save({
            "build_id": "b-" + uuid.uuid4().hex[:16], "state": "queued", "progress": PROGRESS["queued"],
            "created_at": now, "started_at": None, "finished_at": None, "name": name, "video_bytes": len(video),
            "where": self.backend.where, "world_id": None, "error": None, "info": None,
        })
        try:
            future = self._executor.submit(self.backend.build, video, camera)
        except (BrokenProcessPool, RuntimeError):
            self._executor = self.backend.open_executor(self.settings.build_workers)  # a dead pool is replaced, not reused
            future = self._executor.submit(self.backend.build, video, camera)
        self._running.add(future)
        task = asyncio.get_running_loop().create_task(self._follow(record, future))
        self._tasks.add(task)
        task.add_done_callback(self._tasks.discard)
        return record

    async def _follow(self, record: dict, future: Future) -> None:
        deadline = record["created_at"] + self.settings.build_timeout_s
        wrapped = asyncio.wrap_future(future)
        while not wrapped.done():
            if record["state"] == "queued" and future.running():
                record = self._save({**record, "state": "running", "progress": PROGRESS["running"], "started_at": time.time()})
            if time.time() > deadline:
                future.cancel()
                self._finish(record, error=_failure("build_timeout", f"the build did not finish within "
                                                    f"{self.settings.build_timeout_s} s (PHYSMIND_BUILD_TIMEOUT_S)",
                                                    "a shorter video, or a larger PHYSMIND_BUILD_TIMEOUT_S"))
                return
            await asyncio.wait({wrapped}, timeout=POLL_S)
        try:
            built = wrapped.result()
        except asyncio.CancelledError:
            self._finish(record, error=_failure("build_failed", "the build was cancelled (the server is stopping)"))
            return
        except Exception as error:  # the build's own error, pickled back from the worker
            self._finish(record, error=_build_error(error))
            return
        record = self._save({**record, "state": "registering", "progress": PROGRESS["registering"],
                             "started_at": record["started_at"] or time.time(), "info": built.get("info")})
        body = {"world": built["world"], **({"name": record["name"]} if record["name"] else {})}
        try:
            created = json.loads(await self.pool.call("create_world", body))
        except ToolError as error:
            self._finish(record, error=_failure(error.code, error.message, error.expected))
            return
        self._finish(record, world_id=created["world_id"])

    def _finish(self, record: dict, world_id: str | None = None, error: dict | None = None) -> None:
        self._save({**record, "state": "failed" if error else "done", "progress": PROGRESS["done"],
                    "finished_at": time.time(), "world_id": world_id, "error": error})


def build_status_body(record: dict) -> dict[str, Any]:
    """The public view of a job record (what GET /v1/builds/{id} returns)."""
    return {**record, "links": {"self": f"/v1/builds/{record['build_id']}",
                                **({"world": f"/v1/worlds/{record['world_id']}"} if record.get("world_id") else {})}}
