"""Structured tool errors: what every caller (HTTP, planner, MCP) sees instead of a traceback.

An error names the tool, a JSON pointer (RFC 6901) to the offending field of
the arguments, a human message, what was expected, and for not-found errors
the ids that do exist. ``status`` is the HTTP status the server answers with.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Sequence


@dataclass
class ToolError(Exception):
    """A user-facing error of a tool call (never a bug: bugs are plain exceptions).

    code: machine-readable, e.g. ``invalid_arguments``, ``rollout_not_found``.
    pointer: JSON pointer into the arguments ("" = the whole document).
    expected: what a valid value looks like, in words.
    valid_ids: for not-found errors, the ids that do exist.
    status: HTTP status code (422 invalid, 404 not found, 413 too large).
    """

    code: str
    message: str
    tool: str | None = None
    pointer: str = ""
    expected: str | None = None
    valid_ids: Sequence[Any] | None = None
    status: int = 422
    extra: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        super().__init__(self.message)

    def __str__(self) -> str:
        where = f" at {self.pointer!r}" if self.pointer else ""
        return f"{self.tool or 'request'}: {self.code}{where}: {self.message}"

    def to_dict(self) -> dict[str, Any]:
        body: dict[str, Any] = {
            "code": self.code,
            "tool": self.tool,
            "pointer": self.pointer,
            "message": self.message,
            "expected": self.expected,
        }
        if self.valid_ids is not None:
            body["valid_ids"] = list(self.valid_ids)
        body.update(self.extra)
        return {"error": body}


def json_pointer(path: Sequence[Any]) -> str:
    """RFC 6901 pointer for a path of keys/indices, e.g. ("edits", 0, "value") -> "/edits/0/value"."""
    return "".join("/" + str(part).replace("~", "~0").replace("/", "~1") for part in path)


def invalid_argument(tool: str | None, pointer: str, message: str, expected: str | None = None) -> ToolError:
    return ToolError(code="invalid_arguments", message=message, tool=tool, pointer=pointer, expected=expected, status=422)


# An error must stay small: echoed input is cut, and other ids are listed only when few.
MAX_ECHO_CHARS = 80
MAX_LISTED_IDS = 20


def echo(value: Any, limit: int = MAX_ECHO_CHARS) -> str:
    """``repr(value)`` cut to ``limit`` characters."""
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def not_found(kind: str, value: Any, valid_ids: Sequence[Any], *, tool: str | None, pointer: str) -> ToolError:
    """``kind`` is ``rollout``, ``object``, ``world`` or ``tool``; lists ``valid_ids`` when there are few."""
    valid = list(valid_ids)
    if len(valid) > MAX_LISTED_IDS:
        return ToolError(code=f"{kind}_not_found", message=f"unknown {kind} id {echo(value)}; there are {len(valid)} {kind} ids",
                         tool=tool, pointer=pointer, expected=f"one of the {len(valid)} existing {kind} ids", status=404)
    return ToolError(
        code=f"{kind}_not_found",
        message=f"unknown {kind} id {echo(value)}; valid {kind} ids: {valid}",
        tool=tool,
        pointer=pointer,
        expected=f"one of {valid}",
        valid_ids=valid,
        status=404,
    )


def limit_exceeded(tool: str | None, pointer: str, message: str, limit: Any) -> ToolError:
    return ToolError(
        code="limit_exceeded", message=message, tool=tool, pointer=pointer,
        expected=f"<= {limit}", status=422, extra={"limit": limit},
    )


def not_available_in_3d(what: str, available: Sequence[str], tool: str | None = None) -> ToolError:
    """``what`` (a tool, or an endpoint) has no meaning on a 3D world (no edits, no camera there)."""
    listing = f"; the tools that are: {list(available)}" if available else ""
    return ToolError(code="not_available_in_3d", message=f"{what} is not available on a 3D world{listing}",
                     tool=tool, pointer="", expected=f"one of {list(available)}" if available else "a 2D (tabletop) world",
                     status=422)
