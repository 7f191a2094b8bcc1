"""The PhysMind tool server: the FastAPI app factory (the one place that assembles the app).

Endpoints (all JSON; see docs/server.md for a curl walkthrough):

* ``GET  /healthz``                                      liveness (no auth)            server/routes_meta.py
* ``GET  /v1/tools``, ``GET /v1/tools/{tool_name}``      tool listings                 server/routes_tools.py
* ``POST /v1/worlds/{world_id}/tools/{tool_name}``       run a tool                    server/routes_tools.py
* ``POST /v1/worlds``, ``GET /v1/worlds``, ``GET|DELETE /v1/worlds/{world_id}``         server/routes_worlds.py
* ``GET  /v1/worlds/{world_id}/rollouts[/{rollout_id}]`` the rollout registry          server/routes_rollouts.py
* ``POST /v1/builds``, ``GET /v1/builds[/{build_id}]``   build a world from a video     server/routes_builds.py
* ``POST /mcp``                                          MCP, Streamable HTTP          server/mcp.py

Every error is the envelope of schemas/error.schema.json (server/errors.py),
never a traceback. A new router is one line in ``include_routes``.
"""

from __future__ import annotations

from contextlib import asynccontextmanager

from fastapi import FastAPI
from fastapi.middleware.cors import CORSMiddleware
from fastapi.staticfiles import StaticFiles

from server import routes_builds, routes_meta, routes_render, routes_rollouts, routes_tools, routes_worlds
from server.builds import BuildBackend, BuildJobs
from server.errors import install_error_handlers
from server.logs import get_logger
from server.mcp import mount_mcp
from server.middleware import RequestMiddleware
from server.openapi import install_openapi
from server.routes_meta import API_VERSION
from server.settings import Settings
from server.datadir import lock_data_dir, open_store
from server.workers import WorkerPool
from server.world_registry import WorldRegistry
from tools.registry import tool_registry

__all__ = ["API_VERSION", "create_app", "include_routes"]


def include_routes(app: FastAPI) -> None:
    """Every router and mount of the app; another router is one more line here."""
    app.include_router(routes_meta.router)
    app.mount(routes_meta.DOCS_ASSETS_PATH, routes_meta.swagger_assets(), name="docs-assets")
    app.include_router(routes_tools.router)
    app.include_router(routes_worlds.router)
    app.include_router(routes_rollouts.router)
    app.include_router(routes_render.router)
    app.include_router(routes_builds.router)
    app.mount("/viewer", StaticFiles(directory=routes_render.VIEWER_DIR, html=True), name="viewer")


def create_app(settings: Settings | None = None, build_backend: BuildBackend | None = None) -> FastAPI:
    """The FastAPI app with its SQLite registry under ``settings.data_dir``.

    build_backend: how POST /v1/builds builds worlds (handed in by the composition
    root, physmind/serve.py); without one, builds answer 503 builds_unavailable.
    """
    settings = settings or Settings.from_env()
    data_lock = lock_data_dir(settings.data_dir)
    store = open_store(settings.database_path)
    registry = WorldRegistry(store, settings)
    pool = WorkerPool(settings, registry)
    builds = BuildJobs(settings, store, pool, build_backend)
    builds.start()  # here, not in the lifespan: a Dask LocalCluster must start outside the event loop
    logger = get_logger(settings.log_level)

    @asynccontextmanager
    async def lifespan(_: FastAPI):
        logger.info("startup", extra={"fields": {"data_dir": str(settings.data_dir), "auth": bool(settings.api_key),
                                                  "tools": list(tool_registry()),
                                                  "builds": build_backend.where if build_backend else None}})
        pool.warm_up()
        yield
        builds.shutdown()
        pool.shutdown()
        store.close()
        data_lock.close()

    app = FastAPI(
        title="PhysMind tool server",
        version=API_VERSION,
        description="Executable physical worlds served as schema-validated rollout tools. "
                    "Errors are {error: {code, tool, pointer, message, expected}} (schemas/error.schema.json).",
        lifespan=lifespan,
        docs_url=None,  # served by routes_meta from local assets, not a CDN
        redoc_url=None,
    )
    app.state.settings = settings
    app.state.registry = registry
    app.state.store = store
    app.state.pool = pool
    app.state.builds = builds
    install_error_handlers(app, logger)
    include_routes(app)
    mount_mcp(app, registry, pool)  # POST /mcp: the Model Context Protocol (server/mcp.py)
    install_openapi(app, auth_required=bool(settings.api_key), max_horizon_frames=settings.max_horizon_frames)
    if settings.cors_origins:  # off unless origins are listed: no browser page may call the API by default
        app.add_middleware(CORSMiddleware, allow_origins=list(settings.cors_origins), allow_methods=["GET", "POST", "DELETE"],
                           allow_headers=["Authorization", "Content-Type", "X-Request-ID"], expose_headers=["X-Request-ID"])
    app.add_middleware(RequestMiddleware, settings=settings)  # added last: runs first
    return app
