"""HTTP client of the tool server (httpx); the planner's only way to a world.

Every tool call is logged as a :class:`ToolCall` (tool, arguments, HTTP
status, a short digest of the result, duration), so an answer can name the
calls it rests on. Errors of the server keep their structured body
(``{"error": {code, message, pointer, ...}}``) in :class:`ToolCallError`.

    client = ToolClient("http://127.0.0.1:8000")
    world = client.create_world(world_document)           # -> WorldHandle
    summary = world.call("get_world_summary")
    edited = world.call("simulate_edit", edit_type="remove_object", object_id=2)
    world.calls                                          # every ToolCall made through this handle
"""

from __future__ import annotations

import json
import os
import time
from dataclasses import dataclass, field
from typing import Any, Mapping

import httpx

DEFAULT_TIMEOUT_S = 120.0


class ToolCallError(RuntimeError):
    """The server answered a tool call (or another request) with an error status.

    ``status``: HTTP status; ``error``: the server's structured error object
    (``code``, ``message``, ``pointer``, ...) or ``{"message": text}`` when the
    body was not JSON.
    """

    def __init__(self, what: str, status: int, error: Mapping[str, Any]):
        self.status = status
        self.error = dict(error)
        code = self.error.get("code", "error")
        super().__init__(f"{what}: HTTP {status} {code}: {self.error.get('message', '')}")


@dataclass(frozen=True)
class ToolCall:
    """One tool call made over HTTP.

    index: position in the handle's log (0-based), used by answers to cite it.
    status: HTTP status (200 on success). digest: a few fields of the result
    (ids, counts, status) -- the full result stays with the caller.
    duration_ms: wall time of the request, milliseconds.
    """

    index: int
    tool: str
    arguments: Mapping[str, Any]
    status: int
    digest: Mapping[str, Any]
    duration_ms: float

    def to_dict(self) -> dict[str, Any]:
        return {"index": self.index, "tool": self.tool, "arguments": dict(self.arguments), "status": self.status,
                "digest": dict(self.digest), "duration_ms": round(self.duration_ms, 3)}


_DIGEST_KEYS = ("rollout_id", "edited_rollout_id", "status", "count", "first_frame", "object_count", "added_pairs",
                "removed_pairs", "contact", "matched_frames", "frames")


def digest(result: Any) -> dict[str, Any]:
    """The small, citable part of a tool result (ids, counts, statuses)."""
    if not isinstance(result, Mapping):
        return {}
    if "error" in result and isinstance(result["error"], Mapping):
        return {"error": result["error"].get("code"), "message": result["error"].get("message")}
    return {k: result[k] for k in _DIGEST_KEYS if k in result}


def _error_body(response: httpx.Response) -> dict[str, Any]:
    try:
        body = response.json()
    except ValueError:
        return {"message": response.text[:500]}
    if isinstance(body, Mapping) and isinstance(body.get("error"), Mapping):
        return dict(body["error"])
    return {"message": json.dumps(body)[:500]}


class ToolClient:
    """Connection to a PhysMind tool server.

    base_url: e.g. ``http://127.0.0.1:8000``. api_key: bearer token (default
    ``$PHYSMIND_API_KEY``). transport: optional httpx transport (tests).
    """

    def __init__(self, base_url: str, api_key: str | None = None, timeout: float = DEFAULT_TIMEOUT_S,
                 transport: httpx.BaseTransport | None = None):
        if not isinstance(base_url, str) or not base_url.startswith(("http://", "https://")):
            raise ValueError(f"server url: expected http(s)://host:port, got {base_url!r}")
        api_key = api_key if api_key is not None else os.environ.get("PHYSMIND_API_KEY") or None
        headers = {"Authorization": f"Bearer {api_key}"} if api_key else {}
        self.base_url = base_url.rstrip("/")
        self.http = httpx.Client(base_url=self.base_url, timeout=timeout, headers=headers, transport=transport)

    def close(self) -> None:
        self.http.close()

    def __enter__(self) -> "ToolClient":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def _json(self, response: httpx.Response, what: str) -> Any:
        if response.status_code >= 400:
            raise ToolCallError(what, response.status_code, _error_body(response))
        return response.json()

    def health(self) -> dict[str, Any]:
        return self._json(self.http.get("/healthz"), "GET /healthz")

    def tools(self) -> list[dict[str, Any]]:
        """The tools in OpenAI function-calling format (``GET /v1/tools``)."""
        return list(self._json(self.http.get("/v1/tools"), "GET /v1/tools")["tools"])

    def create_world(
        self, document: Mapping[str, Any], name: str | None = None, horizon_frames: int | None = None
    ) -> "WorldHandle":
        """Register a world document (``POST /v1/worlds``); its base rollout is computed by the server.

        horizon_frames: frames of the base rollout (default: the server's, observed + 20 %).
        """
        body: dict[str, Any] = {"world": document}
        if name:
            body["name"] = name
        if horizon_frames is not None:
            body["horizon_frames"] = int(horizon_frames)
        created = self._json(self.http.post("/v1/worlds", json=body), "POST /v1/worlds")
        return WorldHandle(self, created["world_id"])

    def world(self, world_id: str) -> "WorldHandle":
        """A handle on an existing world (checked with ``GET /v1/worlds/{id}``)."""
        self._json(self.http.get(f"/v1/worlds/{world_id}"), f"GET /v1/worlds/{world_id}")
        return WorldHandle(self, world_id)

    def delete_world(self, world_id: str) -> None:
        self._json(self.http.delete(f"/v1/worlds/{world_id}"), f"DELETE /v1/worlds/{world_id}")


@dataclass
class WorldHandle:
    """One world on the server plus the log of the tool calls made on it."""

    client: ToolClient
    world_id: str
    calls: list[ToolCall] = field(default_factory=list)

    def call_raw(self, tool: str, arguments: Mapping[str, Any] | None = None) -> tuple[int, Any, ToolCall]:
        """Run a tool; returns (HTTP status, JSON body, the logged call) without raising on 4xx.

        The VLM loop hands error bodies back to the model so it can correct itself.
        """
        arguments = dict(arguments or {})
        started = time.perf_counter()
        response = self.client.http.post(f"/v1/worlds/{self.world_id}/tools/{tool}", json=arguments)
        duration = (time.perf_counter() - started) * 1e3
        try:
            body = response.json()
        except ValueError:
            body = {"error": {"code": "invalid_response", "message": response.text[:500]}}
        record = ToolCall(len(self.calls), tool, arguments, response.status_code, digest(body), duration)
        self.calls.append(record)
        return response.status_code, body, record

    def call(self, tool: str, **arguments: Any) -> dict[str, Any]:
        """Run a tool and return its result; ToolCallError on an error status."""
        status, body, _ = self.call_raw(tool, arguments)
        if status >= 400:
            raise ToolCallError(f"tool {tool}", status, body.get("error", {}) if isinstance(body, Mapping) else {})
        return body

    @property
    def last_call(self) -> ToolCall:
        return self.calls[-1]
