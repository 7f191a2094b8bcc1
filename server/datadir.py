"""The data directory: one server per directory (an exclusive lock), and a usable SQLite registry in it.

Two servers on one directory would each keep their own caches (a world
deleted through one would still answer on the other), so the second one
refuses to start with a clear error instead. Worker processes of the same
server share the directory without the lock: they re-check existence in
SQLite on every call.
"""

from __future__ import annotations

import fcntl
import sqlite3
from pathlib import Path
from typing import IO

from server.store import SqliteStore

LOCK_NAME = "physmind.lock"


class DataDirError(ValueError):
    """The data directory cannot be used (one line, for the CLI)."""


def lock_data_dir(data_dir: Path | str) -> IO[str]:
    """Create ``data_dir`` if needed and hold its exclusive lock until the returned file is closed."""
    directory = Path(data_dir)
    if directory.exists() and not directory.is_dir():
        raise DataDirError(f"data directory {str(directory)!r} is a file, not a directory")
    try:
        directory.mkdir(parents=True, exist_ok=True)
        handle = open(directory / LOCK_NAME, "a+")
    except OSError as error:
        raise DataDirError(f"cannot use data directory {str(directory)!r}: {error.strerror or error}") from None
    try:
        fcntl.flock(handle.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        handle.close()
        raise DataDirError(f"data directory {str(directory)!r} is in use by another physmind server "
                           "(one server per directory; give this one its own --data-dir)") from None
    return handle


def open_store(database_path: Path | str) -> SqliteStore:
    """The registry at ``database_path``; DataDirError if the file is not a usable SQLite database."""
    path = Path(database_path)
    if path.is_dir():
        raise DataDirError(f"{str(path)!r} is a directory, not the SQLite registry file")
    try:
        store = SqliteStore(path)
        store.check_integrity()
    except sqlite3.DatabaseError as error:
        raise DataDirError(f"{str(path)!r} is not a usable PhysMind registry ({error}); "
                           "move it away or choose another --data-dir") from None
    return store
