"""``physmind serve``: server/serve_cli.py's command with world builds (POST /v1/builds) wired in.

The server may not import perception or the planner; this composition-root
module hands it a ``BuildBackend``: the build function below and the
executor it runs on (local processes, or Dask with ``--dask``).
"""

from __future__ import annotations

import argparse
from typing import Any

from physmind.executors import add_dask_argument, check_dask_address, describe, open_executor
from server import serve_cli
from server.builds import BuildBackend


def build_from_upload(video: bytes, camera: dict) -> dict:
    """Runs in a build worker: an uploaded video and its camera document -> {"world", "info"}."""
    # Lazy: perception and scipy take seconds to import; the server process never needs them, only build workers.
    from physmind.pipeline import build_world_from_video_bytes

    return build_world_from_video_bytes(video, camera)


def register(subparsers: Any) -> None:
    parser = serve_cli.register(subparsers)
    add_dask_argument(parser, "world builds (POST /v1/builds)")
    parser.set_defaults(handler=run_serve)


def run_serve(args: argparse.Namespace) -> int:
    address = check_dask_address(args.dask) if args.dask else None
    backend = BuildBackend(build=build_from_upload, open_executor=lambda workers: open_executor(address, workers),
                           where=describe(address))
    return serve_cli.serve(args, build_backend=backend)
