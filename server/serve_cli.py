"""``physmind serve``: run the tool server with uvicorn.

Settings come from the environment (see server/settings.py); ``--data-dir``
overrides PHYSMIND_DATA_DIR. The API key is read only from PHYSMIND_API_KEY
so it never appears in a process listing.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from server import settings as settings_module


def environment_help() -> str:
    """The ``PHYSMIND_*`` lines of server/settings.py's docstring: one owner for the list of variables."""
    lines = [line for line in (settings_module.__doc__ or "").splitlines() if line.startswith("PHYSMIND_")]
    return "environment variables:\n" + "\n".join(f"  {line}" for line in lines)


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "serve",
        help="serve worlds and rollout tools over HTTP",
        description="Serve executable worlds and the schema-validated rollout tools over HTTP (FastAPI + uvicorn).",
        epilog=environment_help(),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--host", default="127.0.0.1", help="interface to bind (default 127.0.0.1; 0.0.0.0 in Docker)")
    parser.add_argument("--port", type=int, default=8000, help="TCP port (default 8000)")
    parser.add_argument("--data-dir", type=Path, default=None, help="registry directory (default $PHYSMIND_DATA_DIR or ./data)")
    parser.set_defaults(handler=serve)


def uvicorn_log_config(level: str) -> dict:
    """uvicorn's own messages (startup, shutdown, errors) as JSON lines too."""
    return {
        "version": 1,
        "disable_existing_loggers": False,
        "formatters": {"json": {"()": "server.logs.JsonFormatter"}},
        "handlers": {"stderr": {"class": "logging.StreamHandler", "formatter": "json", "stream": "ext://sys.stderr"}},
        "loggers": {"uvicorn": {"handlers": ["stderr"], "level": level, "propagate": False}},
    }


def serve(args: argparse.Namespace) -> int:
    if not 0 < args.port < 65536:
        raise ValueError(f"--port: expected 1..65535, got {args.port}")
    import uvicorn

    from server.app import create_app
    from server.settings import Settings

    settings = Settings.from_env(data_dir=args.data_dir)
    app = create_app(settings)
    # Our middleware writes one JSON line per request; uvicorn's access log would duplicate it.
    uvicorn.run(app, host=args.host, port=args.port, access_log=False, log_level=settings.log_level.lower(),
                log_config=uvicorn_log_config(settings.log_level))
    return 0
