"""Server settings, read from the environment (``PHYSMIND_*``) with explicit overrides.

PHYSMIND_DATA_DIR         directory of the SQLite registry (default ./data)
PHYSMIND_API_KEY          if set, /v1/* requires ``Authorization: Bearer <key>``
PHYSMIND_MAX_REQUEST_BYTES  request bodies above this answer 413 (default 4 MiB)
PHYSMIND_MAX_HORIZON_FRAMES rollouts longer than this answer 422 (default 5000)
PHYSMIND_MAX_BODIES         worlds with more bodies answer 422 (default 256; contact search is quadratic)
PHYSMIND_VALIDATE_RESULTS   "0" skips validating tool results against their schemas (default on)
PHYSMIND_LOG_LEVEL          logging level of the JSON request log (default INFO)
PHYSMIND_TRUSTED_HOSTS      extra Host header names accepted besides the loopback names (comma-separated; "*" = any)
PHYSMIND_CORS_ORIGINS       origins allowed by CORS (comma-separated; default none: CORS off)
PHYSMIND_MAX_COST           per-request budget in body-frames: bodies x horizon frames x detail weight (default 200000)
PHYSMIND_MAX_RESPONSE_BYTES larger responses answer 422 response_too_large (default 16 MiB)
PHYSMIND_REQUEST_TIMEOUT_S  a call still running after this answers 503 with Retry-After (default 60)
PHYSMIND_BODY_TIMEOUT_S     a request body not fully received within this answers 408 (default 10)
PHYSMIND_WORKERS            processes that run the tools and world creation (default: CPU count; 0 = threads)
PHYSMIND_MAX_PENDING        calls queued or running in the workers; more answer 429 with Retry-After (default 64)
PHYSMIND_MAX_STORAGE_BYTES  size of the SQLite files above which creating answers 507 (default 2 GiB)
PHYSMIND_MAX_RENDER_FRAMES  longest rollout drawn by plot.png / video.mp4; longer answers 422 (default 1500)
PHYSMIND_RENDER_CACHE_BYTES memory for cached pictures (default 64 MiB)
PHYSMIND_MAX_UPLOAD_BYTES   video uploads to POST /v1/builds above this answer 413 (default 64 MiB)
PHYSMIND_MAX_BUILDS         build jobs queued or running; more answer 429 with Retry-After (default 4)
PHYSMIND_BUILD_WORKERS      processes that build worlds from videos (default 1; with --dask local, the LocalCluster's workers)
PHYSMIND_BUILD_TIMEOUT_S    a build still running after this fails with build_timeout (default 600)
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
DEFAULT_MAX_COST = 200_000
DEFAULT_MAX_RESPONSE_BYTES = 16 * 1024 * 1024
DEFAULT_REQUEST_TIMEOUT_S = 60
DEFAULT_BODY_TIMEOUT_S = 10
DEFAULT_MAX_PENDING = 64
DEFAULT_MAX_STORAGE_BYTES = 2 * 1024 ** 3
DEFAULT_MAX_UPLOAD_BYTES = 64 * 1024 * 1024
DEFAULT_MAX_BUILDS = 4
DEFAULT_BUILD_WORKERS = 1
DEFAULT_BUILD_TIMEOUT_S = 600
LOOPBACK_HOSTS = ("localhost", "127.0.0.1", "::1")


def _names(env: Mapping[str, str], name: str) -> tuple[str, ...]:
    return tuple(part.strip() for part in (env.get(name) or "").split(",") if part.strip())


def _workers(env: Mapping[str, str]) -> int:
    raw = env.get("PHYSMIND_WORKERS")
    if raw is None or raw == "":
        return max(1, os.cpu_count() or 1)
    if not raw.isdigit():
        raise ValueError(f"PHYSMIND_WORKERS: expected an integer >= 0, got {raw!r}")
    return int(raw)


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
    trusted_hosts: tuple[str, ...] = ()
    cors_origins: tuple[str, ...] = ()
    max_cost: int = DEFAULT_MAX_COST
    max_response_bytes: int = DEFAULT_MAX_RESPONSE_BYTES
    request_timeout_s: int = DEFAULT_REQUEST_TIMEOUT_S
    body_timeout_s: int = DEFAULT_BODY_TIMEOUT_S
    workers: int = 0
    max_pending: int = DEFAULT_MAX_PENDING
    max_storage_bytes: int = DEFAULT_MAX_STORAGE_BYTES
    max_upload_bytes: int = DEFAULT_MAX_UPLOAD_BYTES
    max_builds: int = DEFAULT_MAX_BUILDS
    build_workers: int = DEFAULT_BUILD_WORKERS
    build_timeout_s: int = DEFAULT_BUILD_TIMEOUT_S

    @property
    def accepted_hosts(self) -> tuple[str, ...]:
        """Host header names this server answers (loopback names plus the trusted ones)."""
        return (*LOOPBACK_HOSTS, *self.trusted_hosts)

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
            trusted_hosts=_names(env, "PHYSMIND_TRUSTED_HOSTS"),
            cors_origins=_names(env, "PHYSMIND_CORS_ORIGINS"),
            max_cost=_int(env, "PHYSMIND_MAX_COST", DEFAULT_MAX_COST),
            max_response_bytes=_int(env, "PHYSMIND_MAX_RESPONSE_BYTES", DEFAULT_MAX_RESPONSE_BYTES),
            request_timeout_s=_int(env, "PHYSMIND_REQUEST_TIMEOUT_S", DEFAULT_REQUEST_TIMEOUT_S),
            body_timeout_s=_int(env, "PHYSMIND_BODY_TIMEOUT_S", DEFAULT_BODY_TIMEOUT_S),
            workers=_workers(env),
            max_pending=_int(env, "PHYSMIND_MAX_PENDING", DEFAULT_MAX_PENDING),
            max_storage_bytes=_int(env, "PHYSMIND_MAX_STORAGE_BYTES", DEFAULT_MAX_STORAGE_BYTES),
            max_upload_bytes=_int(env, "PHYSMIND_MAX_UPLOAD_BYTES", DEFAULT_MAX_UPLOAD_BYTES),
            max_builds=_int(env, "PHYSMIND_MAX_BUILDS", DEFAULT_MAX_BUILDS),
            build_workers=_int(env, "PHYSMIND_BUILD_WORKERS", DEFAULT_BUILD_WORKERS),
            build_timeout_s=_int(env, "PHYSMIND_BUILD_TIMEOUT_S", DEFAULT_BUILD_TIMEOUT_S),
        )
        return replace(settings, **{k: v for k, v in overrides.items() if v is not None})
