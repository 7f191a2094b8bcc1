"""SQLite registries of worlds and rollouts, safe under concurrent requests.

One embedded file (``<data_dir>/physmind.sqlite3``) in WAL mode; every thread
gets its own connection, multi-statement writes run in ``BEGIN IMMEDIATE``
transactions and a busy timeout serialises writers. Rollouts are immutable,
stored as zlib-compressed JSON documents (``world.io.rollout_to_dict``), and
kept decoded in a small LRU cache so inspection calls do not re-parse them.
A restart re-opens the same file: every world and rollout answers as before.
Build jobs (``POST /v1/builds``) are rows of their status record (JSON).
"""

from __future__ import annotations

import json
import sqlite3
import threading
import time
import zlib
from collections import OrderedDict
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from world.io import edit_to_tool_record, rollout_from_dict, rollout_to_dict, world_from_dict
from world.types import Rollout, World

SCHEMA_SQL = """
CREATE TABLE IF NOT EXISTS worlds (
    world_id   TEXT PRIMARY KEY,
    name       TEXT NOT NULL,
    created_at REAL NOT NULL,
    body_count INTEGER NOT NULL,
    document   TEXT NOT NULL
);
CREATE TABLE IF NOT EXISTS rollouts (
    seq            INTEGER PRIMARY KEY AUTOINCREMENT,
    world_id       TEXT NOT NULL REFERENCES worlds(world_id) ON DELETE CASCADE,
    rollout_id     TEXT NOT NULL,
    parent_id      TEXT,
    created_at     REAL NOT NULL,
    horizon_frames INTEGER NOT NULL,
    edits          TEXT NOT NULL,
    document       BLOB NOT NULL,
    UNIQUE (world_id, rollout_id)
);
CREATE TABLE IF NOT EXISTS builds (
    build_id   TEXT PRIMARY KEY,
    created_at REAL NOT NULL,
    record     TEXT NOT NULL
);
"""


class WorldGone(KeyError):
    """The world was deleted (or never existed) while a rollout was being stored."""


@dataclass(frozen=True)
class WorldRow:
    world_id: str
    name: str
    created_at: float
    body_count: int
    rollout_count: int


@dataclass(frozen=True)
class RolloutRow:
    rollout_id: str
    parent_id: str | None
    created_at: float
    horizon_frames: int
    edits: list[dict[str, Any]]


def _encode(document: dict) -> bytes:
    return zlib.compress(json.dumps(document, separators=(",", ":"), allow_nan=False).encode(), 1)


def _decode(blob: bytes) -> dict:
    return json.loads(zlib.decompress(blob))


def _edits_of(rollout: Rollout) -> list[dict[str, Any]]:
    return [edit_to_tool_record(e) for e in rollout.edits]


class SqliteStore:
    """World and rollout registry. Thread-safe; implements tools.session.RolloutStore."""

    def __init__(self, path: Path | str, cache_size: int = 256) -> None:
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._local = threading.local()
        self._connections: list[sqlite3.Connection] = []
        self._connections_lock = threading.Lock()
        self._cache: OrderedDict[tuple[str, str], Any] = OrderedDict()
        self._cache_lock = threading.Lock()
        self._cache_size = cache_size
        self._conn().executescript(SCHEMA_SQL)

    # -- connections ----------------------------------------------------------
    def _conn(self) -> sqlite3.Connection:
        conn = getattr(self._local, "conn", None)
        if conn is None:
            conn = sqlite3.connect(self.path, timeout=30.0, isolation_level=None, check_same_thread=False)
            conn.execute("PRAGMA journal_mode=WAL")
            conn.execute("PRAGMA synchronous=NORMAL")
            conn.execute("PRAGMA foreign_keys=ON")
            conn.execute("PRAGMA busy_timeout=30000")
            self._local.conn = conn
            with self._connections_lock:
                self._connections.append(conn)
        return conn

    class _Tx:
        def __init__(self, conn: sqlite3.Connection) -> None:
            self.conn = conn

        def __enter__(self) -> sqlite3.Connection:
            self.conn.execute("BEGIN IMMEDIATE")
            return self.conn

        def __exit__(self, exc_type: Any, *_: Any) -> None:
            self.conn.execute("ROLLBACK" if exc_type else "COMMIT")

    def _transaction(self) -> "SqliteStore._Tx":
        return SqliteStore._Tx(self._conn())

    def close(self) -> None:
        with self._connections_lock:
            for conn in self._connections:
                try:
                    conn.close()
                except sqlite3.Error:
                    pass
            self._connections.clear()
        self._local = threading.local()

    # -- cache ----------------------------------------------------------------
    def _cached(self, key: tuple[str, str]) -> Any:
        with self._cache_lock:
            value = self._cache.get(key)
            if value is not None:
                self._cache.move_to_end(key)
            return value

    def _remember(self, key: tuple[str, str], value: Any) -> None:
        with self._cache_lock:
            self._cache[key] = value
            self._cache.move_to_end(key)
            while len(self._cache) > self._cache_size:
                self._cache.popitem(last=False)

    def forget_world(self, world_id: str) -> None:
        """Drop a world's cached objects (another process deleted it)."""
        self._forget_world(world_id)

    def _forget_world(self, world_id: str) -> None:
        with self._cache_lock:
            for key in [k for k in self._cache if k[0] == world_id]:
                del self._cache[key]

    # -- worlds ---------------------------------------------------------------
    def create_world(self, world_id: str, world: Any, document: dict, base: Rollout | None, name: str | None = None) -> None:
        """Store a world and its base rollout atomically (``name`` defaults to the document's id).

        A 3D world (world.scene3d) comes with ``base=None`` and a ``name``: its rollouts are recomputed from their ids.
        """
        now = time.time()
        rollout_blob = None if base is None else _encode(rollout_to_dict(base))
        with self._transaction() as conn:
            conn.execute(
                "INSERT INTO worlds (world_id, name, created_at, body_count, document) VALUES (?, ?, ?, ?, ?)",
                (world_id, name or world.id, now, len(world.bodies), json.dumps(document, separators=(",", ":"), allow_nan=False)),
            )
            if base is not None:
                conn.execute(
                    "INSERT INTO rollouts (world_id, rollout_id, parent_id, created_at, horizon_frames, edits, document) VALUES (?, ?, ?, ?, ?, ?, ?)",
                    (world_id, base.id, None, now, base.horizon_frames, json.dumps(_edits_of(base)), rollout_blob),
                )
        if base is not None:
            self._remember((world_id, "\0world"), world)
            self._remember((world_id, base.id), base)

    def list_worlds(self) -> list[WorldRow]:
        rows = self._conn().execute(
            "SELECT w.world_id, w.name, w.created_at, w.body_count, "
            "(SELECT COUNT(*) FROM rollouts r WHERE r.world_id = w.world_id) "
            "FROM worlds w ORDER BY w.created_at, w.world_id"
        ).fetchall()
        return [WorldRow(*row) for row in rows]

    def world_ids(self) -> list[str]:
        return [row[0] for row in self._conn().execute("SELECT world_id FROM worlds ORDER BY created_at, world_id")]

    def world_row(self, world_id: str) -> WorldRow | None:
        for row in self._conn().execute(
            "SELECT w.world_id, w.name, w.created_at, w.body_count, "
            "(SELECT COUNT(*) FROM rollouts r WHERE r.world_id = w.world_id) FROM worlds w WHERE w.world_id = ?",
            (world_id,),
        ):
            return WorldRow(*row)
        return None

    def world_document(self, world_id: str) -> dict | None:
        row = self._conn().execute("SELECT document FROM worlds WHERE world_id = ?", (world_id,)).fetchone()
        return None if row is None else json.loads(row[0])

    def get_world(self, world_id: str) -> World | None:
        key = (world_id, "\0world")
        world = self._cached(key)
        if world is None:
            document = self.world_document(world_id)
            if document is None:
                return None

            world = world_from_dict(document)
            self._remember(key, world)
        return world

    def check_integrity(self) -> None:
        """sqlite3.DatabaseError unless the file is a readable database with our tables."""
        # Reading a row reads the header and the schema; a full integrity check would be O(database).
        self._conn().execute("SELECT world_id FROM worlds LIMIT 1").fetchone()

    def has_world(self, world_id: str) -> bool:
        return self._conn().execute("SELECT 1 FROM worlds WHERE world_id = ?", (world_id,)).fetchone() is not None

    def size_bytes(self) -> int:
        """Bytes of the database file and its WAL on disk (what the storage quota counts)."""
        total = 0
        for suffix in ("", "-wal"):
            try:
                total += Path(f"{self.path}{suffix}").stat().st_size
            except FileNotFoundError:
                pass
        return total

    def delete_world(self, world_id: str) -> bool:
        with self._transaction() as conn:
            deleted = conn.execute("DELETE FROM worlds WHERE world_id = ?", (world_id,)).rowcount
        self._forget_world(world_id)
        return deleted > 0

    # -- rollouts (tools.session.RolloutStore) --------------------------------
    def get_rollout(self, world_id: str, rollout_id: str) -> Rollout | None:
        key = (world_id, rollout_id)
        rollout = self._cached(key)
        if rollout is None:
            row = self._conn().execute(
                "SELECT document FROM rollouts WHERE world_id = ? AND rollout_id = ?", (world_id, rollout_id)
            ).fetchone()
            if row is None:
                return None

            rollout = rollout_from_dict(_decode(row[0]))
            self._remember(key, rollout)
        return rollout

    def rollout_document(self, world_id: str, rollout_id: str) -> dict | None:
        row = self._conn().execute(
            "SELECT document FROM rollouts WHERE world_id = ? AND rollout_id = ?", (world_id, rollout_id)
        ).fetchone()
        return None if row is None else _decode(row[0])

    def put_rollout(self, world_id: str, rollout: Rollout, parent_id: str | None) -> None:
        blob = _encode(rollout_to_dict(rollout))
        try:
            with self._transaction() as conn:
                conn.execute(
                    "INSERT INTO rollouts (world_id, rollout_id, parent_id, created_at, horizon_frames, edits, document) VALUES (?, ?, ?, ?, ?, ?, ?)",
                    (world_id, rollout.id, parent_id, time.time(), rollout.horizon_frames, json.dumps(_edits_of(rollout)), blob),
                )
        except sqlite3.IntegrityError as error:
            if "FOREIGN KEY" in str(error):
                raise WorldGone(world_id) from None
            raise
        self._remember((world_id, rollout.id), rollout)

    def rollout_ids(self, world_id: str) -> list[str]:
        return [row[0] for row in self._conn().execute(
            "SELECT rollout_id FROM rollouts WHERE world_id = ? ORDER BY seq", (world_id,))]

    def list_rollouts(self, world_id: str) -> list[RolloutRow]:
        rows = self._conn().execute(
            "SELECT rollout_id, parent_id, created_at, horizon_frames, edits FROM rollouts WHERE world_id = ? ORDER BY seq",
            (world_id,),
        ).fetchall()
        return [RolloutRow(r[0], r[1], r[2], r[3], json.loads(r[4])) for r in rows]

    def rollout_row(self, world_id: str, rollout_id: str) -> RolloutRow | None:
        r = self._conn().execute(
            "SELECT rollout_id, parent_id, created_at, horizon_frames, edits FROM rollouts WHERE world_id = ? AND rollout_id = ?",
            (world_id, rollout_id),
        ).fetchone()
        return None if r is None else RolloutRow(r[0], r[1], r[2], r[3], json.loads(r[4]))


    # -- build jobs -------------------------------------------------------------
    def put_build(self, build_id: str, created_at: float, record: dict) -> None:
        """Insert or replace the status record of a build job."""
        self._conn().execute("INSERT OR REPLACE INTO builds (build_id, created_at, record) VALUES (?, ?, ?)",
                             (build_id, created_at, json.dumps(record, separators=(",", ":"), allow_nan=False)))

    def get_build(self, build_id: str) -> dict | None:
        row = self._conn().execute("SELECT record FROM builds WHERE build_id = ?", (build_id,)).fetchone()
        return None if row is None else json.loads(row[0])

    def list_builds(self) -> list[dict]:
        return [json.loads(row[0]) for row in self._conn().execute("SELECT record FROM builds ORDER BY created_at, build_id")]

    def build_ids(self) -> list[str]:
        return [row[0] for row in self._conn().execute("SELECT build_id FROM builds ORDER BY created_at, build_id")]
