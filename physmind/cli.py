"""The ``physmind`` command line.

This package is the composition root: the only place that wires the stages
(perception, identification, tool server, planner) together. Each capability
registers its own subcommand from a small ``cli`` module (``synth/cli.py``,
``server/serve_cli.py``, ...) exposing ``register(subparsers) -> None``; the
commands that cross stages (build, ask, eval, demo) live here in
``physmind/``. A registered handler receives the parsed ``argparse.Namespace``
and returns an exit code.
"""

from __future__ import annotations

import argparse
import importlib
import sys
from pathlib import Path
from typing import Sequence

import httpx

from physmind import __version__
from physmind.errors import CliError
from planner.client import ToolCallError

# Modules that provide ``register(subparsers)``; missing ones are skipped so a
# partial install still serves the subcommands it has.
SUBCOMMAND_MODULES: tuple[str, ...] = (
    "physmind.demo",
    "synth.cli",
    "perception.cli",
    "world.identify.cli",
    "physmind.commands",
    "physmind.serve",  # server.serve_cli's `serve` with world builds (POST /v1/builds) wired in
    "server.mcp_cli",
    "planner.cli",
    "render.cli",
)



# Options that name a file to write, by argparse dest; a directory there is a user error caught before any work.
OUTPUT_FILE_OPTIONS = {"output": "-o/--output", "json": "--json", "report": "--report", "png": "--png"}


def check_output_files(args: argparse.Namespace) -> None:
    """CliError if an option that names an output file names an existing directory."""
    for dest, flag in OUTPUT_FILE_OPTIONS.items():
        value = getattr(args, dest, None)
        if isinstance(value, Path) and value.is_dir():
            raise CliError(f"{flag}: {str(value)!r} is a directory; give a file name")


def _user_error_types() -> tuple[type[BaseException], ...]:
    """Errors that are the user's input or environment, never a bug: one line, exit code 2."""
    types: list[type[BaseException]] = [CliError, ValueError, OSError, httpx.HTTPError]
    try:  # the planner's client reports a server's structured refusal

        types.append(ToolCallError)
    except ModuleNotFoundError:
        pass
    return tuple(types)


def _one_line(error: BaseException) -> str:
    text = " ".join(str(error).split()) or type(error).__name__
    if isinstance(error, httpx.TransportError):
        try:
            where = f" at {error.request.url.scheme}://{error.request.url.netloc.decode()}"
        except RuntimeError:  # no request attached
            where = ""
        text = f"cannot reach the tool server{where} ({text})"
    return text if len(text) <= 500 else text[:497] + "..."


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="physmind",
        description="Video -> executable physical world -> schema-validated tools over HTTP.",
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND")
    for module_name in SUBCOMMAND_MODULES:
        try:
            module = importlib.import_module(module_name)
        except ModuleNotFoundError as error:
            # Only skip modules that do not exist yet; a broken import inside an
            # existing module is a bug and must surface.
            if error.name is not None and module_name.startswith(error.name):
                continue
            raise
        module.register(subparsers)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    handler = getattr(args, "handler", None)
    if handler is None:
        parser.print_help()
        return 2
    try:
        check_output_files(args)
        return int(handler(args) or 0)
    except _user_error_types() as error:
        print(f"physmind {args.command}: error: {_one_line(error)}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"physmind {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
