"""``physmind serve``: run the tool server with uvicorn.

Settings come from the environment (see server/settings.py); flags override
them. The API key is read only from PHYSMIND_API_KEY so it never appears in a
process listing. Safe by default: a non-loopback address needs a key (or an
explicit ``--insecure``), and every problem with the host, port or data
directory is a one-line error (exit code 2) before uvicorn starts.
"""

from __future__ import annotations

import argparse
import ipaddress
import socket
from dataclasses import replace
from pathlib import Path
from typing import Any

from server import settings as settings_module


def environment_help() -> str:
    """The ``PHYSMIND_*`` lines of server/settings.py's docstring: one owner for the list of variables."""
    lines = [line for line in (settings_module.__doc__ or "").splitlines() if line.startswith("PHYSMIND_")]
    return "environment variables:\n" + "\n".join(f"  {line}" for line in lines)


def register(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Add ``serve``; returns its parser so the composition root (physmind/serve.py) can add the build options."""
    parser = subparsers.add_parser(
        "serve",
        help="serve worlds and rollout tools over HTTP",
        description="Serve executable worlds and the schema-validated rollout tools over HTTP (FastAPI + uvicorn).",
        epilog=environment_help(),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--host", default="127.0.0.1",
                        help="interface to bind (default 127.0.0.1); a non-loopback address needs PHYSMIND_API_KEY or --insecure")
    parser.add_argument("--port", type=int, default=8000, help="TCP port (default 8000)")
    parser.add_argument("--data-dir", type=Path, default=None, help="registry directory (default $PHYSMIND_DATA_DIR or ./data)")
    parser.add_argument("--insecure", action="store_true",
                        help="allow a non-loopback address without an API key (anyone who reaches the port can use the server)")
    parser.add_argument("--trusted-host", action="append", default=[], metavar="NAME",
                        help="accept this Host header name besides the loopback names (repeatable; '*' = any)")
    parser.add_argument("--cors-origin", action="append", default=[], metavar="ORIGIN",
                        help="allow cross-origin browser calls from this origin (repeatable; default: CORS off)")
    parser.add_argument("--workers", type=int, default=None, help="worker processes for the tools (default: CPU count; 0 = threads)")
    parser.set_defaults(handler=serve)
    return parser


def uvicorn_log_config(level: str) -> dict:
    """uvicorn's own messages (startup, shutdown, errors) as JSON lines too."""
    return {
        "version": 1,
        "disable_existing_loggers": False,
        "formatters": {"json": {"()": "server.logs.JsonFormatter"}},
        "handlers": {"stderr": {"class": "logging.StreamHandler", "formatter": "json", "stream": "ext://sys.stderr"}},
        "loggers": {"uvicorn": {"handlers": ["stderr"], "level": level, "propagate": False}},
    }


def is_loopback(host: str) -> bool:
    if host.lower() == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def check_bind(host: str, port: int) -> None:
    """ValueError (one line) if ``host`` does not resolve or ``host:port`` cannot be bound now."""
    try:
        infos = socket.getaddrinfo(host, port, type=socket.SOCK_STREAM, flags=socket.AI_PASSIVE)
    except (socket.gaierror, UnicodeError) as error:
        raise ValueError(f"--host: cannot resolve {host!r} ({error})") from None
    family, kind, proto, _, address = infos[0]
    with socket.socket(family, kind, proto) as probe:
        probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)  # as uvicorn does
        try:
            probe.bind(address)
        except OSError as error:
            reason = "is already in use" if error.errno in (98, 48) else f"cannot be bound ({error.strerror})"
            raise ValueError(f"--host/--port: {host}:{port} {reason}") from None


def serve(args: argparse.Namespace, build_backend: Any = None) -> int:
    """Run the server; ``build_backend`` (a server.builds.BuildBackend) enables POST /v1/builds."""
    if not 0 < args.port < 65536:
        raise ValueError(f"--port: expected 1..65535, got {args.port}")
    if args.workers is not None and args.workers < 0:
        raise ValueError(f"--workers: expected an integer >= 0, got {args.workers}")
    # Lazy: loaded only when this command runs, so `physmind --help` and the other commands start fast.
    from server.settings import Settings

    settings = Settings.from_env(data_dir=args.data_dir, workers=args.workers)
    settings = replace(settings, trusted_hosts=(*settings.trusted_hosts, *args.trusted_host),
                       cors_origins=(*settings.cors_origins, *args.cors_origin))
    if not is_loopback(args.host) and not settings.api_key and not args.insecure:
        raise ValueError(f"--host {args.host}: refusing to serve a non-loopback address without an API key; "
                         "set PHYSMIND_API_KEY (clients send 'Authorization: Bearer <key>') or pass --insecure")
    check_bind(args.host, args.port)
    # Lazy: loaded only when this command runs, so `physmind --help` and the other commands start fast.
    import uvicorn

    from server.app import create_app

    app = create_app(settings, build_backend)  # DataDirError (a ValueError) for an unusable or busy data directory
    # Our middleware writes one JSON line per request; uvicorn's access log would duplicate it.
    uvicorn.run(app, host=args.host, port=args.port, access_log=False, log_level=settings.log_level.lower(),
                log_config=uvicorn_log_config(settings.log_level), timeout_keep_alive=5)
    return 0
