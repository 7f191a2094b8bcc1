"""Server settings, read from the environment (``PHYSMIND_*``) with explicit overrides.

PHYSMIND_DATA_DIR         directory of the SQLite registry (default ./data)
PHYSMIND_API_KEY          if set, /v1/* requires ``Authorization: Bearer <key>``
PHYSMIND_MAX_REQUEST_BYTES  request bodies above this answer 413 (default 4 MiB)
PHYSMIND_MAX_HORIZON_FRAMES rollouts longer than this answer 422 (default 5000)
PHYSMIND_MAX_BODIES         worlds with more bodies answer 422 (default 256; contact search is quadratic)
PHYSMIND_VALIDATE_RESULTS   "0" skips validating tool results against their schemas (default on)
PHYSMIND_LOG_LEVEL          logging level of the JSON request log (default INFO)
"""

from __future__ import annotations

import os
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Mapping

DEFAULT_DATA_DIR = Path("data")
DEFAULT_MAX_REQUEST_BYTES = 4 * 1024 * 1024
DEFAULT_MAX_HORIZON_FRAMES = 5000
DEFAULT_MAX_BODIES = 256


def _int(env: Mapping[str, str], name: str, default: int) -> int:
    raw = env.get(name)
    if raw is None or raw == "":
        return default
    try:
        value = int(raw)
    except ValueError:
        raise ValueError(f"{name}: expected an integer, got {raw!r}") from None
    if value <= 0:
        raise ValueError(f"{name}: must be > 0, got {value}")
    return value


@dataclass(frozen=True)
class Settings:
    data_dir: Path = DEFAULT_DATA_DIR
    api_key: str | None = None
    max_request_bytes: int = DEFAULT_MAX_REQUEST_BYTES
    max_horizon_frames: int = DEFAULT_MAX_HORIZON_FRAMES
    max_bodies: int = DEFAULT_MAX_BODIES
    validate_results: bool = True
    log_level: str = "INFO"

    @property
    def database_path(self) -> Path:
        return Path(self.data_dir) / "physmind.sqlite3"

    @classmethod
    def from_env(cls, env: Mapping[str, str] | None = None, **overrides: Any) -> "Settings":
        """Settings from ``env`` (default os.environ); non-None ``overrides`` win."""
        env = os.environ if env is None else env
        settings = cls(
            data_dir=Path(env.get("PHYSMIND_DATA_DIR") or DEFAULT_DATA_DIR),
            api_key=env.get("PHYSMIND_API_KEY") or None,
            max_request_bytes=_int(env, "PHYSMIND_MAX_REQUEST_BYTES", DEFAULT_MAX_REQUEST_BYTES),
            max_horizon_frames=_int(env, "PHYSMIND_MAX_HORIZON_FRAMES", DEFAULT_MAX_HORIZON_FRAMES),
            max_bodies=_int(env, "PHYSMIND_MAX_BODIES", DEFAULT_MAX_BODIES),
            validate_results=env.get("PHYSMIND_VALIDATE_RESULTS", "1") not in ("0", "false", "no"),
            log_level=(env.get("PHYSMIND_LOG_LEVEL") or "INFO").upper(),
        )
        return replace(settings, **{k: v for k, v in overrides.items() if v is not None})
