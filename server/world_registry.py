"""Worlds and their tool sessions over one SqliteStore: what the world, rollout and tool routes call.

Thread-safe. Every check on a new world runs before anything is stored, so a
failed create leaves no trace.
"""

from __future__ import annotations

import dataclasses
import threading
import uuid
from typing import Any

import jsonschema
import numpy as np
from fastapi import Request
from jsonschema.exceptions import best_match

from schemas import read_schema
from server.costs import check_cost, request_cost, tool_call_cost
from server.errors import parse_json
from server.routes_render import picture_links
from server.settings import Settings
from server.store import SqliteStore, WorldGone
from tools.common import boundaries, event_record
from tools.errors import ToolError, echo, invalid_argument, json_pointer, limit_exceeded, not_available_in_3d, not_found
from tools.registry import call_tool, get_tool, inline_refs, tool_registry, validation_error_to_tool_error
from tools.scene3d import World3DSession
from tools.session import BASE_ROLLOUT_ID, MemoryRolloutStore, WorldSession, default_horizon_frames
from world.io import world_from_dict
from world.rollout import simulate
from world.scene3d.io import PHYSION_SCHEMA, is_world3d_document, validate_physion, world3d_from_dict, world3d_to_dict
from world.types import Rollout

WORLD_SCHEMA_NAME = "world.schema.json"
WORLD_SOURCES = ("world", "observations", "video")


class WorldRegistry:
    """Worlds and their tool sessions over one SqliteStore (thread-safe)."""

    def __init__(self, store: SqliteStore, settings: Settings) -> None:
        self.store = store
        self.settings = settings
        self._sessions: dict[str, WorldSession | World3DSession] = {}
        self._lock = threading.Lock()
        self._world_validator = self._load_world_validator()

    @staticmethod
    def _load_world_validator() -> Any:
        return jsonschema.Draft202012Validator(read_schema(WORLD_SCHEMA_NAME))

    def unknown_world(self, world_id: str, tool: str | None = None) -> ToolError:
        return not_found("world", world_id, self.store.world_ids(), tool=tool, pointer="")

    def session(self, world_id: str, tool: str | None = None) -> WorldSession | World3DSession:
        # Asked of SQLite every time: another process of this server (the one that answered a
        # DELETE) may have deleted the world while this one still caches it.
        if not self.store.has_world(world_id):
            with self._lock:
                self._sessions.pop(world_id, None)
            self.store.forget_world(world_id)
            raise self.unknown_world(world_id, tool)
        with self._lock:
            session = self._sessions.get(world_id)
        if session is not None:
            return session
        document = self.store.world_document(world_id)
        if is_world3d_document(document):
            row = self.store.world_row(world_id)
            session = World3DSession(world_id, world3d_from_dict(document), self.settings.max_horizon_frames,
                                     name=row.name if row else None)
            with self._lock:
                return self._sessions.setdefault(world_id, session)
        world = self.store.get_world(world_id)
        if world is None:
            raise self.unknown_world(world_id, tool)
        session = WorldSession(world_id, world, self.store, max_horizon_frames=self.settings.max_horizon_frames)
        with self._lock:
            return self._sessions.setdefault(world_id, session)

    def create_world(self, body: Any) -> dict:
        if not isinstance(body, dict):
            raise invalid_argument(None, "", "the request body must be a JSON object", '{"world": {...world document...}}')
        for key in body:
            if key not in (*WORLD_SOURCES, "name", "horizon_frames"):
                raise invalid_argument(None, json_pointer([key]), f"unknown property {echo(key)}",
                                       f"only {[*WORLD_SOURCES, 'name', 'horizon_frames']}")
        sources = [k for k in WORLD_SOURCES if k in body]
        if len(sources) != 1:
            raise invalid_argument(None, "/world", f"give exactly one world source, got {sources or 'none'}",
                                   f"exactly one of {list(WORLD_SOURCES)}")
        if sources[0] != "world":
            raise ToolError(code="unsupported_source", tool=None, pointer=json_pointer([sources[0]]), status=422,
                            message=f"creating a world from {sources[0]!r} is not available in this version; "
                                    "fit it first (physmind fit) and POST the world document under 'world'",
                            expected="a 'world' document")
        name = body.get("name")
        if name is not None and (not isinstance(name, str) or not 0 < len(name) <= 200):
            raise invalid_argument(None, "/name", "name must be a string of 1..200 characters", "a string of 1..200 characters")
        document = body["world"]
        if not isinstance(document, dict):
            raise invalid_argument(None, "/world", "the world document must be a JSON object", "a world document (schemas/world.schema.json)")
        bodies = document.get("bodies")
        if isinstance(bodies, list) and len(bodies) > self.settings.max_bodies:
            raise limit_exceeded(None, "/world/bodies", f"{len(bodies)} bodies exceed this server's limit of "
                                 f"{self.settings.max_bodies}", self.settings.max_bodies)
        if is_world3d_document(document):
            return self._create_world3d(body, document, name)
        if self._world_validator is not None:
            error = best_match(self._world_validator.iter_errors(document))
            if error is not None:
                raise validation_error_to_tool_error(error, None, prefix="/world")
        try:
            world = world_from_dict(document)
        except (ValueError, KeyError, TypeError) as error:
            raise ToolError(code="invalid_world", tool=None, pointer="/world", status=422,
                            message=str(error)[:500], expected="a valid world document (schemas/world.schema.json)") from None
        horizon = body.get("horizon_frames", default_horizon_frames(world))
        if isinstance(horizon, bool) or not isinstance(horizon, int) or horizon < 1:
            raise invalid_argument(None, "/horizon_frames", f"horizon_frames must be an integer >= 1, got {echo(horizon)}",
                                   "an integer number of frames >= 1")
        if horizon > self.settings.max_horizon_frames:
            raise limit_exceeded(None, "/world/observed_frames",
                                 f"the base rollout would need {horizon} frames, above this server's limit of "
                                 f"{self.settings.max_horizon_frames}", self.settings.max_horizon_frames)
        check_cost(request_cost(len(world.bodies), horizon), self.settings.max_cost, tool=None,
                   pointer="/horizon_frames" if "horizon_frames" in body else "/world/bodies", what="the base rollout")
        self.check_storage()
        try:
            base = simulate(world, (), horizon_frames=horizon, rollout_id=BASE_ROLLOUT_ID)
        except (ValueError, FloatingPointError, OverflowError, ZeroDivisionError) as error:
            raise ToolError(code="invalid_world", tool=None, pointer="/world", status=422,
                            message=str(error)[:500], expected="a world the engine can execute") from None
        world_id = "w-" + uuid.uuid4().hex[:16]
        # Everything is checked before anything is stored: the summary on a scratch session first
        # (its result schema rejects non-finite values), then the world and its base rollout at once.
        scratch = MemoryRolloutStore()
        scratch.put_rollout(world_id, base, None)
        try:
            summary = call_tool("get_world_summary", WorldSession(world_id, world, scratch), {}, validate_results=True)
            _require_finite_rollout(base)
        except (AssertionError, ValueError, FloatingPointError, OverflowError) as error:
            raise ToolError(code="invalid_world", tool=None, pointer="/world", status=422,
                            message=f"the world does not execute to finite, valid values: {str(error)[:300]}",
                            expected="physically plausible masses, sizes, velocities and fps") from None
        self.store.create_world(world_id, world, document, base, name=name or world.id)
        session = WorldSession(world_id, world, self.store, max_horizon_frames=self.settings.max_horizon_frames)
        with self._lock:
            self._sessions[world_id] = session
        return {"world_id": world_id, "name": name or world.id, "rollout_ids": [BASE_ROLLOUT_ID], "summary": summary}

    def _create_world3d(self, body: dict, document: dict, name: str | None) -> dict:
        """A 3D world (physion.schema.json#/$defs/world3d): checked in full (its base continuation runs
        and its summary validates) before the document is stored; its rollouts are recomputed from their ids."""
        try:
            validate_physion(document, "world3d")
            world = world3d_from_dict(document)
        except (ValueError, KeyError, TypeError) as error:
            raise ToolError(code="invalid_world", tool=None, pointer="/world", status=422, message=str(error)[:500],
                            expected="a valid 3D world document (schemas/physion.schema.json#/$defs/world3d)") from None
        horizon = body.get("horizon_frames")
        if horizon is not None:
            if isinstance(horizon, bool) or not isinstance(horizon, int) or horizon < world.observed_frames:
                raise invalid_argument(None, "/horizon_frames", f"horizon_frames must be an integer >= the observed frames "
                                       f"({world.observed_frames}), got {echo(horizon)}", f"an integer >= {world.observed_frames}")
            world = dataclasses.replace(world, horizon_frames=horizon)
        scratch = World3DSession("w-check", world, self.settings.max_horizon_frames)
        horizon = scratch.default_horizon_frames()
        if horizon > self.settings.max_horizon_frames:
            raise limit_exceeded(None, "/world/horizon_frames", f"the base continuation would need {horizon} frames, above "
                                 f"this server's limit of {self.settings.max_horizon_frames}", self.settings.max_horizon_frames)
        check_cost(request_cost(len(world.bodies), horizon), self.settings.max_cost, tool=None,
                   pointer="/horizon_frames" if "horizon_frames" in body else "/world/bodies", what="the base rollout")
        self.check_storage()
        world_id = "w-" + uuid.uuid4().hex[:16]
        session = World3DSession(world_id, world, self.settings.max_horizon_frames, name=name or "world3d")
        try:
            summary = call_tool("get_world_summary", session, {}, validate_results=True)
        except (AssertionError, ValueError, FloatingPointError, OverflowError, ZeroDivisionError) as error:
            raise ToolError(code="invalid_world", tool=None, pointer="/world", status=422,
                            message=f"the world does not execute to finite, valid values: {str(error)[:300]}",
                            expected="physically plausible masses, sizes, velocities and fps") from None
        self.store.create_world(world_id, world, world3d_to_dict(world), None, name=name or "world3d")
        with self._lock:
            self._sessions[world_id] = session
        return {"world_id": world_id, "name": name or "world3d", "rollout_ids": [BASE_ROLLOUT_ID], "summary": summary}

    def check_storage(self) -> None:
        """507 when the data directory's SQLite files exceed the storage quota."""
        used = self.store.size_bytes()
        if used > self.settings.max_storage_bytes:
            raise ToolError(code="storage_quota_exceeded", tool=None, pointer="", status=507,
                            message=f"the data directory holds {used} bytes, above this server's quota of "
                                    f"{self.settings.max_storage_bytes} (PHYSMIND_MAX_STORAGE_BYTES); delete worlds to make room",
                            expected="fewer stored worlds", extra={"limit": self.settings.max_storage_bytes})

    def create_world_from_bytes(self, raw: bytes) -> dict:
        return self.create_world(parse_json(raw, None, None))

    def delete_world(self, world_id: str) -> dict:
        if not self.store.delete_world(world_id):
            raise self.unknown_world(world_id)
        with self._lock:
            self._sessions.pop(world_id, None)
        return {"deleted": world_id}

    def run_tool(self, world_id: str, tool_name: str, raw: bytes) -> dict:
        get_tool(tool_name)  # 404 listing the tools before anything else
        args = parse_json(raw, tool_name, {})
        session = self.session(world_id, tool_name)
        default = session.default_horizon_frames() if session.is_3d else default_horizon_frames(session.world)
        cost = tool_call_cost(tool_name, args, len(session.world.bodies), default)
        if cost:
            check_cost(cost, self.settings.max_cost, tool=tool_name, pointer="/horizon_frames", what=f"this {tool_name} call")
            self.check_storage()
        try:
            return call_tool(tool_name, session, args, validate_results=self.settings.validate_results)
        except WorldGone:
            with self._lock:
                self._sessions.pop(world_id, None)
            raise self.unknown_world(world_id, tool_name) from None

    def rollout_summary(self, world_id: str, rollout_id: str, detail: str) -> dict:
        session = self.session(world_id)
        if session.is_3d:
            raise not_available_in_3d("GET /v1/worlds/{id}/rollouts/{id} (use list_events or continue_world)", _tools_3d())
        rollout: Rollout = session.rollout(rollout_id, tool=None, pointer="")
        row = self.store.rollout_row(world_id, rollout_id)
        payload: dict[str, Any] = {
            "world_id": world_id,
            "rollout_id": rollout_id,
            "parent_id": row.parent_id if row else None,
            "created_at": row.created_at if row else None,
            "edits": row.edits if row else [],
            "object_ids": [int(b) for b in rollout.body_ids],
            "boundaries": boundaries(rollout),
            "events": [event_record(e, rollout.observed_frames) for e in rollout.events],
            "links": picture_links(world_id, rollout_id),
        }
        if detail == "full":
            payload["rollout"] = self.store.rollout_document(world_id, rollout_id)
        return payload


def _tools_3d() -> list[str]:
    return [tool.name for tool in tool_registry().values() if tool.spec.run3d is not None]


def _require_finite_rollout(rollout: Rollout) -> None:
    """ValueError if any state of ``rollout`` is NaN or infinite."""
    for name in ("times", "positions", "velocities", "yaw"):
        values = getattr(rollout, name, None)
        if values is not None and not np.all(np.isfinite(np.asarray(values, dtype=float))):
            raise ValueError(f"the rollout's {name} are not finite")


def world_body_schema() -> dict:
    """The request body of POST /v1/worlds, for the OpenAPI document.

    A 3D world (Physion++-style, "format": "physmind.world3d/1") is accepted too.
    Only the source this version accepts is published; 'observations' and
    'video' are reserved names that answer 422 unsupported_source.
    """
    return {
        "type": "object",
        "description": "a world document under 'world' (exactly one source; 'observations' and 'video' are reserved)",
        "properties": {
            "world": {"anyOf": [inline_refs(read_schema(WORLD_SCHEMA_NAME), read_schema, WORLD_SCHEMA_NAME),
                                inline_refs({"$ref": f"{PHYSION_SCHEMA}#/$defs/world3d"}, read_schema)],
                      "description": "a tabletop world (world.schema.json) or a 3D world (physion.schema.json#/$defs/world3d)"},
            "name": {"type": "string", "minLength": 1, "maxLength": 200},
            "horizon_frames": {"type": "integer", "minimum": 1,
                               "description": "frames of the base rollout (default: observed frames + 20 %)"},
        },
        "required": ["world"],
        "additionalProperties": False,
    }


def pool_of(request: Request) -> Any:
    """The WorkerPool (server.workers) of the app serving ``request``."""
    return request.app.state.pool


def registry_of(request: Request) -> WorldRegistry:
    """The WorldRegistry of the app serving ``request``."""
    return request.app.state.registry
