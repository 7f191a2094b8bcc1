"""Pictures of rollouts over HTTP, and the web viewer's static files.

* ``GET /v1/worlds/{world_id}/rollouts/{rollout_id}/plot.png``  top-down still: the rollout beside
  its reference (``reference``, default ``base``; one panel when they are the same), event timeline
* ``GET /v1/worlds/{world_id}/rollouts/{rollout_id}/video.mp4`` the same as an h264 replay

Rendered on demand in a worker thread and kept in an in-memory LRU cache (rollouts are immutable,
so an id always draws the same). Limits (environment, read when the app is built):

PHYSMIND_MAX_RENDER_FRAMES   videos of longer rollouts answer 422 limit_exceeded (default 1500)
PHYSMIND_RENDER_CACHE_BYTES  cache budget in bytes (default 64 MiB); larger single renders are not kept

The overlay over the source video is a CLI product only (``physmind render --video``): the server
does not keep videos.
"""

from __future__ import annotations

import os
import threading
from collections import OrderedDict
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

from fastapi import APIRouter, Query, Request
from fastapi.responses import Response
from starlette.concurrency import run_in_threadpool

from server.openapi_docs import responses
from tools.errors import limit_exceeded, not_available_in_3d
from tools.session import BASE_ROLLOUT_ID

VIEWER_DIR = Path(__file__).resolve().parent / "static" / "viewer"
DEFAULT_MAX_RENDER_FRAMES = 1500
DEFAULT_RENDER_CACHE_BYTES = 64 * 1024 * 1024
PANEL_WIDTHS = (160, 1280)  # inclusive bounds of the ``width`` query parameter, pixels

router = APIRouter(tags=["render"])
PLOT_PATH = "/v1/worlds/{world_id}/rollouts/{rollout_id}/plot.png"
VIDEO_PATH = "/v1/worlds/{world_id}/rollouts/{rollout_id}/video.mp4"


def picture_links(world_id: str, rollout_id: str) -> dict[str, str]:
    """The server-relative URLs of a rollout's pictures, as the rollout endpoints list them."""
    return {"plot_png": PLOT_PATH.format(world_id=world_id, rollout_id=rollout_id),
            "video_mp4": VIDEO_PATH.format(world_id=world_id, rollout_id=rollout_id)}


def _positive_int(name: str, default: int) -> int:
    raw = os.environ.get(name, "")
    if not raw:
        return default
    if not raw.isdigit() or int(raw) <= 0:
        raise ValueError(f"{name}: expected a positive integer, got {raw!r}")
    return int(raw)


@dataclass(frozen=True)
class RenderLimits:
    max_frames: int = DEFAULT_MAX_RENDER_FRAMES
    cache_bytes: int = DEFAULT_RENDER_CACHE_BYTES

    @classmethod
    def from_env(cls) -> "RenderLimits":
        return cls(_positive_int("PHYSMIND_MAX_RENDER_FRAMES", DEFAULT_MAX_RENDER_FRAMES),
                   _positive_int("PHYSMIND_RENDER_CACHE_BYTES", DEFAULT_RENDER_CACHE_BYTES))


class RenderCache:
    """Least-recently-used bytes, bounded by their total size (thread-safe)."""

    def __init__(self, budget_bytes: int) -> None:
        self.budget = budget_bytes
        self.size = 0
        self._items: OrderedDict[tuple, bytes] = OrderedDict()
        self._lock = threading.Lock()

    def get(self, key: tuple) -> bytes | None:
        with self._lock:
            data = self._items.get(key)
            if data is not None:
                self._items.move_to_end(key)
            return data

    def put(self, key: tuple, data: bytes) -> None:
        if len(data) > self.budget // 4:  # one huge render must not flush everything else
            return
        with self._lock:
            old = self._items.pop(key, None)
            self.size -= len(old) if old is not None else 0
            self._items[key] = data
            self.size += len(data)
            while self.size > self.budget:
                _, dropped = self._items.popitem(last=False)
                self.size -= len(dropped)


def _state(request: Request) -> tuple[RenderLimits, RenderCache]:
    """Per-app limits and cache, created on first use (the router is shared by every app)."""
    state = request.app.state
    if not hasattr(state, "render_cache"):
        limits = RenderLimits.from_env()
        state.render_limits, state.render_cache = limits, RenderCache(limits.cache_bytes)
    return state.render_limits, state.render_cache


def _rollouts(request: Request, world_id: str, rollout_id: str, reference: str):
    """(session, rollout, reference rollout); 404 ToolError for unknown ids (checked even on a cache hit)."""
    session = request.app.state.registry.session(world_id)
    if session.is_3d:  # the pictures draw tabletop rollouts
        raise not_available_in_3d("the pictures (plot.png, video.mp4)", [])
    rollout = session.rollout(rollout_id, tool=None, pointer="")
    return session, rollout, session.rollout(reference, tool=None, pointer="/reference")


def _render(request: Request, key: tuple, world_id: str, rollout_id: str, reference: str, width: int,
            draw: Callable[[object], bytes]) -> tuple[bytes, str]:
    """Bytes of ``draw(board)`` for the comparison board, from the cache when present; (bytes, "hit"|"miss")."""
    # Lazy: Pillow and PyAV load at the first picture request, not in every worker process.
    from render.compose import comparison

    limits, cache = _state(request)
    session, rollout, reference_rollout = _rollouts(request, world_id, rollout_id, reference)
    data = cache.get(key)
    if data is not None:
        return data, "hit"
    edited = None if reference == rollout_id else rollout
    board = comparison(session.world, reference_rollout, edited, width, width * 3 // 4)
    data = draw(board)
    cache.put(key, data)
    return data, "miss"


def _picture(data: bytes, cache_status: str, media_type: str) -> Response:
    # Rollout ids are immutable, so a client may keep the picture; "private" because of the bearer token.
    headers = {"X-Render-Cache": cache_status, "Cache-Control": "private, max-age=3600"}
    return Response(content=data, media_type=media_type, headers=headers)


def _responses(media_type: str) -> dict:
    """The error envelope of every route, with the picture as the success body."""
    out = responses(200)
    out["200"] = {"description": "the picture", "content": {media_type: {"schema": {"type": "string", "format": "binary"}}}}
    return out


REFERENCE = Query(BASE_ROLLOUT_ID, max_length=64, description="rollout drawn beside this one (the factual 'base' by default); "
                                                               "equal to rollout_id for a single panel")


@router.get(PLOT_PATH, operation_id="rollout_plot", response_class=Response, responses=_responses("image/png"))
async def rollout_plot(request: Request, world_id: str, rollout_id: str, reference: str = REFERENCE,
                       frame: int | None = Query(None, ge=0, le=1_000_000, description="draw this frame (default: last frame, full trails)"),
                       width: int = Query(480, ge=PANEL_WIDTHS[0], le=PANEL_WIDTHS[1], description="panel width, pixels")) -> Response:
    """Top-down still of a rollout beside its reference, with the event timeline (diverging events highlighted)."""
    # Lazy: Pillow and PyAV load at the first picture request, not in every worker process.
    from render.compose import png_bytes

    def draw(board) -> bytes:
        return png_bytes(board.image(None if frame is None else min(frame, board.horizon_frames - 1)))

    key = ("png", world_id, rollout_id, reference, width, frame)
    data, status = await run_in_threadpool(_render, request, key, world_id, rollout_id, reference, width, draw)
    return _picture(data, status, "image/png")


@router.get(VIDEO_PATH, operation_id="rollout_video", response_class=Response, responses=_responses("video/mp4"))
async def rollout_video(request: Request, world_id: str, rollout_id: str, reference: str = REFERENCE) -> Response:
    """Top-down h264 replay of a rollout beside its reference, with a cursor on the event timeline."""
    # Lazy: Pillow and PyAV load at the first picture request, not in every worker process.
    from render.video import encode_mp4

    limits, _ = _state(request)

    def draw(board) -> bytes:
        if board.horizon_frames > limits.max_frames:
            raise limit_exceeded(None, "", f"a video of {board.horizon_frames} frames exceeds this server's render limit "
                                 f"of {limits.max_frames} frames (PHYSMIND_MAX_RENDER_FRAMES)", limits.max_frames)
        return encode_mp4(board.frames(), board.fps)

    key = ("mp4", world_id, rollout_id, reference)
    data, status = await run_in_threadpool(_render, request, key, world_id, rollout_id, reference, 480, draw)
    return _picture(data, status, "video/mp4")
