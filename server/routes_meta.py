"""Meta routes: liveness and the offline API docs (Swagger UI served from the installed package, no CDN)."""

from __future__ import annotations

from pathlib import Path

import swagger_ui_bundle
from fastapi import APIRouter
from fastapi.openapi.docs import get_swagger_ui_html
from fastapi.responses import HTMLResponse, Response
from starlette.staticfiles import StaticFiles

from server.contract import response_schema
from server.errors import json_response
from server.openapi_docs import responses
from tools.registry import tool_registry

API_VERSION = "0.1.0"
DOCS_ASSETS_PATH = "/docs/assets"

router = APIRouter(tags=["meta"])


@router.get("/healthz", operation_id="healthz", responses=responses(200, response_schema("health"), errors=()))
def healthz() -> Response:
    return json_response({"status": "ok", "version": API_VERSION, "tools": len(tool_registry())})


@router.get("/docs", include_in_schema=False)
def docs() -> HTMLResponse:
    return get_swagger_ui_html(openapi_url="/openapi.json", title="PhysMind tool server",
                               swagger_js_url=f"{DOCS_ASSETS_PATH}/swagger-ui-bundle.js",
                               swagger_css_url=f"{DOCS_ASSETS_PATH}/swagger-ui.css",
                               swagger_favicon_url=f"{DOCS_ASSETS_PATH}/favicon-32x32.png")


def swagger_assets() -> StaticFiles:
    """The Swagger UI files of the swagger-ui-bundle-v2 package, for mounting at DOCS_ASSETS_PATH."""
    return StaticFiles(directory=Path(swagger_ui_bundle.swagger_ui_path))
