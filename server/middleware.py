"""Pure ASGI middleware: request ids, bearer auth, body size limit (413), JSON access log."""

from __future__ import annotations

import hmac
import uuid
from typing import Callable

from server.errors import error_response
from server.logs import get_logger, now_ms
from server.settings import Settings
from tools.errors import ToolError


class RequestMiddleware:
    """Pure ASGI: request ids, bearer auth, body size limit (413), JSON access log."""

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
            rejection = self._authorize(path, headers)
            if rejection is None:
                rejection, receive = await self._limit_body(headers, receive)
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

    def _authorize(self, path: str, headers: dict[str, str]) -> ToolError | None:
        if self._api_key is None or not path.startswith("/v1"):
            return None
        given = headers.get("authorization", "")
        scheme, _, token = given.partition(" ")
        if scheme.lower() == "bearer" and hmac.compare_digest(token.strip().encode(), self._api_key):
            return None
        return ToolError(code="unauthorized", tool=None, pointer="", status=401,
                         message="missing or wrong bearer token", expected="header 'Authorization: Bearer <PHYSMIND_API_KEY>'")

    async def _limit_body(self, headers: dict[str, str], receive: Callable) -> tuple[ToolError | None, Callable]:
        limit = self.settings.max_request_bytes

        def too_large(size: str) -> ToolError:
            return ToolError(code="payload_too_large", tool=None, pointer="", status=413,
                             message=f"request body of {size} bytes exceeds the limit of {limit} bytes",
                             expected=f"a body of at most {limit} bytes", extra={"limit": limit})

        declared = headers.get("content-length")
        if declared is not None and declared.isdigit() and int(declared) > limit:
            return too_large(declared), receive
        # Buffer the body (bounded by the limit) so chunked uploads are limited too.
        chunks: list[bytes] = []
        size = 0
        more = True
        while more:
            message = await receive()
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
