"""``physmind mcp``: serve the tools over MCP on stdin/stdout (the form desktop agent hosts launch).

The worlds live in the same SQLite registry as ``physmind serve`` uses
(``--data-dir`` or PHYSMIND_DATA_DIR), so a world created over HTTP is
there over stdio too. Logs go to stderr; stdout carries only the protocol.
"""

from __future__ import annotations

import argparse
from pathlib import Path


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "mcp", help="serve worlds and rollout tools over MCP on stdio",
        description="Serve the PhysMind tools over the Model Context Protocol on stdin/stdout. "
                    "Streamable HTTP is served by `physmind serve` at /mcp. Environment: PHYSMIND_DATA_DIR and the "
                    "limits of `physmind serve`.")
    parser.add_argument("--data-dir", type=Path, default=None, help="registry directory (default $PHYSMIND_DATA_DIR or ./data)")
    parser.set_defaults(handler=serve_stdio)


def serve_stdio(args: argparse.Namespace) -> int:
    # Lazy: the MCP SDK and the server stack load only for `physmind mcp`.
    import anyio
    from mcp.server.stdio import stdio_server

    from server.datadir import open_store
    from server.mcp import build_mcp_server
    from server.routes_meta import API_VERSION
    from server.settings import Settings
    from server.workers import WorkerPool
    from server.world_registry import WorldRegistry

    settings = Settings.from_env(data_dir=args.data_dir)
    store = open_store(settings.database_path)
    registry = WorldRegistry(store, settings)
    pool = WorkerPool(settings, registry)
    server = build_mcp_server(registry, pool, API_VERSION)

    async def run() -> None:
        async with stdio_server() as (read_stream, write_stream):
            await server.run(read_stream, write_stream, server.create_initialization_options())

    try:
        anyio.run(run)
    finally:
        pool.shutdown()
        store.close()
    return 0
