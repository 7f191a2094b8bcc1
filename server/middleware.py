"""Pure ASGI middleware: request ids, trusted Host (400), bearer auth (401), JSON-only bodies (415),
cross-origin uploads (403), body size limit (413) and upload timeout (408), JSON access log."""

from __future__ import annotations

import asyncio
import hmac
import uuid
from typing import Callable

from server.errors import error_response
from server.logs import get_logger, now_ms
from server.settings import Settings
from tools.errors import ToolError


BODY_METHODS = ("POST", "PUT", "PATCH")
JSON_MEDIA_TYPES = ("application/json",)
PROTECTED_PREFIXES = ("/v1", "/mcp")  # need the bearer token when PHYSMIND_API_KEY is set
# Paths whose bodies are not JSON (the multipart video upload): their routes check the type themselves,
# their bodies are limited by PHYSMIND_MAX_UPLOAD_BYTES, and a browser may not post them cross-site.
UPLOAD_PREFIXES: tuple[str, ...] = ("/v1/builds",)


def host_name(host_header: str) -> str:
    """The name part of a Host header: "[::1]:8000" -> "::1", "localhost:8000" -> "localhost"."""
    host = host_header.strip().lower()
    if host.startswith("["):
        return host[1:host.find("]")] if "]" in host else host
    return host.rsplit(":", 1)[0] if host.count(":") == 1 else host


def is_json_media_type(content_type: str) -> bool:
    media = content_type.split(";", 1)[0].strip().lower()
    return media in JSON_MEDIA_TYPES or (media.startswith("application/") and media.endswith("+json"))


class RequestMiddleware:
    """Pure ASGI: the checks every request passes before any route sees it."""

    PUBLIC_PREFIXES = ("/healthz", "/docs", "/openapi.json", "/redoc")

    def __init__(self, app: Callable, settings: Settings) -> None:
        self.app = app
        self.settings = settings
        self.logger = get_logger(settings.log_level)
        self._api_key = settings.api_key.encode() if settings.api_key else None

    async def __call__(self, scope: dict, receive: Callable, send: Callable) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        started = now_ms()
        headers = {k.decode("latin-1").lower(): v.decode("latin-1") for k, v in scope.get("headers", [])}
        incoming = headers.get("x-request-id", "")
        request_id = incoming if 0 < len(incoming) <= 64 and incoming.isprintable() and incoming.isascii() else uuid.uuid4().hex
        state = scope.setdefault("state", {})
        state["request_id"] = request_id
        status_holder = {"status": 500}

        async def send_with_id(message: dict) -> None:
            if message["type"] == "http.response.start":
                status_holder["status"] = message["status"]
                message.setdefault("headers", [])
                message["headers"] = [*message["headers"], (b"x-request-id", request_id.encode())]
            await send(message)

        path = scope.get("path", "")
        try:
            method = scope.get("method", "")
            upload = method in BODY_METHODS and path.startswith(UPLOAD_PREFIXES)
            rejection = (self._check_host(headers) or self._authorize(path, headers)
                         or (self._check_origin(headers) if upload else self._check_content_type(method, headers)))
            if rejection is None:
                limit = ((self.settings.max_upload_bytes, "PHYSMIND_MAX_UPLOAD_BYTES") if upload
                         else (self.settings.max_request_bytes, "PHYSMIND_MAX_REQUEST_BYTES"))
                rejection, receive = await self._limit_body(headers, receive, *limit)
            if rejection is not None:
                await error_response(rejection, request_id)(scope, receive, send_with_id)
            else:
                await self.app(scope, receive, send_with_id)
        finally:
            fields = {
                "request_id": request_id,
                "method": scope.get("method"),
                "path": path,
                "status": status_holder["status"],
                "duration_ms": round(now_ms() - started, 3),
                "client": (scope.get("client") or ("", 0))[0],
                **state.get("log_fields", {}),
            }
            self.logger.info("request", extra={"fields": fields})

    def _check_host(self, headers: dict[str, str]) -> ToolError | None:
        """DNS rebinding guard: a browser page on evil.example resolving to 127.0.0.1 still sends its own Host."""
        accepted = self.settings.accepted_hosts
        if "*" in accepted or "host" not in headers:
            return None
        name = host_name(headers["host"])
        if name in accepted:
            return None
        return ToolError(code="untrusted_host", tool=None, pointer="", status=400,
                         message=f"Host {name[:80]!r} is not one this server answers to",
                         expected=f"one of {list(accepted)} (add names with PHYSMIND_TRUSTED_HOSTS or --trusted-host)")

    def _check_origin(self, headers: dict[str, str]) -> ToolError | None:
        """A multipart POST is one a cross-site page may send without a preflight; browsers always add
        Origin to it, so an upload from an origin not on the CORS allow-list never reaches a route."""
        origin = headers.get("origin")
        if origin is None or origin in self.settings.cors_origins:
            return None
        return ToolError(code="forbidden_origin", tool=None, pointer="", status=403,
                         message=f"uploads from the browser origin {origin[:80]!r} are not allowed",
                         expected="a client without an Origin header, or an origin listed in PHYSMIND_CORS_ORIGINS")

    def _check_content_type(self, method: str, headers: dict[str, str]) -> ToolError | None:
        """Only application/json bodies: a cross-site form or text/plain POST never reaches a route."""
        if method not in BODY_METHODS:
            return None
        has_body = headers.get("content-length", "0") != "0" or "transfer-encoding" in headers
        content_type = headers.get("content-type")
        if content_type is None and not has_body:
            return None
        if content_type is not None and is_json_media_type(content_type):
            return None
        return ToolError(code="unsupported_media_type", tool=None, pointer="", status=415,
                         message=f"request bodies must be application/json, got {(content_type or 'no Content-Type')[:80]!r}",
                         expected="header 'Content-Type: application/json'")

    def _authorize(self, path: str, headers: dict[str, str]) -> ToolError | None:
        if self._api_key is None or not path.startswith(PROTECTED_PREFIXES):
            return None
        given = headers.get("authorization", "")
        scheme, _, token = given.partition(" ")
        if scheme.lower() == "bearer" and hmac.compare_digest(token.strip().encode(), self._api_key):
            return None
        return ToolError(code="unauthorized", tool=None, pointer="", status=401,
                         message="missing or wrong bearer token", expected="header 'Authorization: Bearer <PHYSMIND_API_KEY>'")

    async def _limit_body(self, headers: dict[str, str], receive: Callable, limit: int, setting: str) -> tuple[ToolError | None, Callable]:

        def too_large(size: str) -> ToolError:
            return ToolError(code="payload_too_large", tool=None, pointer="", status=413,
                             message=f"request body of {size} bytes exceeds the limit of {limit} bytes"
                                     f" ({setting})",
                             expected=f"a body of at most {limit} bytes", extra={"limit": limit})

        declared = headers.get("content-length")
        if declared is not None and declared.isdigit() and int(declared) > limit:
            return too_large(declared), receive
        # Buffer the body (bounded by the limit) so chunked uploads are limited too.
        chunks: list[bytes] = []
        size = 0
        more = True
        deadline = asyncio.get_running_loop().time() + self.settings.body_timeout_s
        while more:
            try:
                message = await asyncio.wait_for(receive(), max(0.0, deadline - asyncio.get_running_loop().time()))
            except asyncio.TimeoutError:
                return ToolError(code="request_timeout", tool=None, pointer="", status=408,
                                 message=f"the request body was not received within {self.settings.body_timeout_s} s "
                                         "(PHYSMIND_BODY_TIMEOUT_S)", expected="a complete request body"), receive
            if message["type"] != "http.request":
                break
            chunk = message.get("body", b"")
            size += len(chunk)
            if size > limit:
                return too_large(f"more than {limit}"), receive
            chunks.append(chunk)
            more = message.get("more_body", False)
        body = b"".join(chunks)
        delivered = False

        async def replay() -> dict:
            nonlocal delivered
            if not delivered:
                delivered = True
                return {"type": "http.request", "body": body, "more_body": False}
            return await receive()

        return None, replay
