"""A world plus its rollout registry: the context every tool runs in.

The same :class:`WorldSession` serves the HTTP server (backed by SQLite, see
``server/store.py``) and in-process callers (backed by :class:`MemoryRolloutStore`).
Rollouts are immutable: once registered under an id, that id always answers
the same. The base rollout (no edits, default horizon) is computed once per
world and reused.
"""

from __future__ import annotations

import threading
import uuid
from dataclasses import dataclass, field
from typing import ClassVar, Protocol, Sequence

from tools.errors import limit_exceeded, not_found
from world.rollout import default_horizon, simulate
from world.types import Edit, Rollout, World

BASE_ROLLOUT_ID = "base"
DEFAULT_MAX_HORIZON_FRAMES = 5000
CONTINUATION_PREFIX = "continue-"


def default_horizon_frames(world: World) -> int:
    """The engine's default horizon: ceil(observed_frames * 1.2), at least one frame."""
    return int(default_horizon(world))


def continuation_id(horizon_frames: int) -> str:
    """The fixed id of the factual continuation to ``horizon_frames`` (continue_world)."""
    return f"{CONTINUATION_PREFIX}{int(horizon_frames)}"


def new_rollout_id() -> str:
    """A fresh, collision-free rollout id (random, so parallel creators never clash)."""
    return "r-" + uuid.uuid4().hex[:16]


class RolloutStore(Protocol):
    """Where a world's rollouts live. Implementations must be thread-safe."""

    def get_rollout(self, world_id: str, rollout_id: str) -> Rollout | None: ...

    def put_rollout(self, world_id: str, rollout: Rollout, parent_id: str | None) -> None: ...

    def rollout_ids(self, world_id: str) -> list[str]:
        """All ids of the world, in creation order ("base" first)."""
        ...


class MemoryRolloutStore:
    """In-process rollout store (tests, planner running tools locally)."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._rollouts: dict[tuple[str, str], Rollout] = {}
        self._order: dict[str, list[str]] = {}
        self.parents: dict[tuple[str, str], str | None] = {}

    def get_rollout(self, world_id: str, rollout_id: str) -> Rollout | None:
        with self._lock:
            return self._rollouts.get((world_id, rollout_id))

    def put_rollout(self, world_id: str, rollout: Rollout, parent_id: str | None) -> None:
        with self._lock:
            key = (world_id, rollout.id)
            if key in self._rollouts:
                raise ValueError(f"rollout id {rollout.id!r} already registered for world {world_id!r}")
            self._rollouts[key] = rollout
            self.parents[key] = parent_id
            self._order.setdefault(world_id, []).append(rollout.id)

    def rollout_ids(self, world_id: str) -> list[str]:
        with self._lock:
            return list(self._order.get(world_id, []))


@dataclass
class WorldSession:
    """One world and access to its rollouts.

    world_id: registry id (may differ from ``world.id``, the document's own name).
    max_horizon_frames: requests for longer rollouts are refused (422).
    """

    world_id: str
    world: World
    store: RolloutStore
    max_horizon_frames: int = DEFAULT_MAX_HORIZON_FRAMES
    is_3d: ClassVar[bool] = False  # tools.scene3d.World3DSession serves 3D worlds
    _base_lock: threading.Lock = field(default_factory=threading.Lock, repr=False)

    # -- lookup ---------------------------------------------------------------
    def rollout_ids(self) -> list[str]:
        ids = self.store.rollout_ids(self.world_id)
        if BASE_ROLLOUT_ID not in ids:
            ids = [BASE_ROLLOUT_ID, *ids]
        return ids

    def base_rollout(self) -> Rollout:
        """The unedited rollout, computed on first use and registered (once)."""
        rollout = self.store.get_rollout(self.world_id, BASE_ROLLOUT_ID)
        if rollout is not None:
            return rollout
        with self._base_lock:
            rollout = self.store.get_rollout(self.world_id, BASE_ROLLOUT_ID)
            if rollout is None:
                horizon = default_horizon_frames(self.world)
                self.check_horizon(horizon, tool=None, pointer="/observed_frames")
                rollout = _simulate(self.world, (), horizon, BASE_ROLLOUT_ID)
                self.store.put_rollout(self.world_id, rollout, None)
            return rollout

    def rollout(self, rollout_id: str, *, tool: str | None, pointer: str = "/rollout_id") -> Rollout:
        """The rollout registered under ``rollout_id``; 404 ToolError listing valid ids otherwise."""
        if rollout_id == BASE_ROLLOUT_ID:
            return self.base_rollout()
        rollout = self.store.get_rollout(self.world_id, rollout_id)
        if rollout is None:
            raise not_found("rollout", rollout_id, self.rollout_ids(), tool=tool, pointer=pointer)
        return rollout

    def latest_edited_rollout_id(self) -> str | None:
        edited = [r for r in self.store.rollout_ids(self.world_id) if r != BASE_ROLLOUT_ID]
        return edited[-1] if edited else None

    def check_object(self, object_id: object, *, tool: str | None, pointer: str) -> int:
        """``object_id`` if the world has it; 404 ToolError listing valid ids otherwise."""
        if object_id not in self.world.body_ids:
            raise not_found("object", object_id, self.world.body_ids, tool=tool, pointer=pointer)
        return int(object_id)  # type: ignore[arg-type]

    def check_horizon(self, horizon_frames: int, *, tool: str | None, pointer: str) -> None:
        if horizon_frames > self.max_horizon_frames:
            raise limit_exceeded(
                tool, pointer,
                f"horizon of {horizon_frames} frames exceeds this server's limit of {self.max_horizon_frames}",
                self.max_horizon_frames,
            )

    # -- creation -------------------------------------------------------------
    def register_factual_rollout(self, horizon_frames: int, rollout_id: str) -> Rollout:
        """The unedited world (anchored continuation) to ``horizon_frames`` under ``rollout_id``;
        an id registered concurrently by another caller is returned as is."""
        rollout = _simulate(self.world, (), int(horizon_frames), rollout_id)
        try:
            self.store.put_rollout(self.world_id, rollout, BASE_ROLLOUT_ID)
        except Exception:  # a duplicate id (memory store: ValueError, SQLite: IntegrityError)
            existing = self.store.get_rollout(self.world_id, rollout_id)
            if existing is None:
                raise
            return existing
        return rollout

    def create_rollout(self, edits: Sequence[Edit], horizon_frames: int | None, parent_id: str | None) -> Rollout:
        """Simulate ``world`` with ``edits`` under a fresh id and register it."""
        horizon = default_horizon_frames(self.world) if horizon_frames is None else int(horizon_frames)
        rollout = _simulate(self.world, tuple(edits), horizon, new_rollout_id())
        self.store.put_rollout(self.world_id, rollout, parent_id)
        return rollout


def _simulate(world: World, edits: tuple[Edit, ...], horizon_frames: int, rollout_id: str) -> Rollout:
    return simulate(world, edits, horizon_frames=horizon_frames, rollout_id=rollout_id)
