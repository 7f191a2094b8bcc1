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
from typing import Sequence

from physmind import __version__
from physmind.errors import CliError

# Modules that provide ``register(subparsers)``; missing ones are skipped so a
# partial install still serves the subcommands it has.
SUBCOMMAND_MODULES: tuple[str, ...] = (
    "physmind.demo",
    "synth.cli",
    "perception.cli",
    "world.identify.cli",
    "physmind.commands",
    "server.serve_cli",
    "server.mcp_cli",
    "planner.cli",
)



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
        return int(handler(args) or 0)
    except (CliError, ValueError, FileNotFoundError) as error:
        print(f"physmind {args.command}: error: {error}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"physmind {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
