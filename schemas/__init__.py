"""PhysMind's JSON Schemas (draft 2020-12), shipped as package data.

The contract of every document and tool: ``world.schema.json``,
``rollout.schema.json``, the CLEVRER annotation and question files, and
``tools/<name>.args.json`` / ``tools/<name>.result.json``. Read them through
this module (``importlib.resources``), never through ``__file__`` paths, so
an installed wheel finds them as a checkout does. This package holds data
only and imports nothing of ours, so every other package may read it.
"""

from __future__ import annotations

import json
from importlib.resources import files
from typing import Any


def read_schema(relative_path: str) -> dict[str, Any]:
    """The schema at ``relative_path`` below this package, e.g. ``"tools/check_contact.args.json"``.

    Raises:
        FileNotFoundError: no such schema in the installed package.
    """
    resource = files(__name__).joinpath(relative_path)
    if not resource.is_file():
        raise FileNotFoundError(f"no schema {relative_path!r} in the installed physmind schemas package")
    return json.loads(resource.read_text(encoding="utf-8"))


def schema_names(folder: str = "") -> list[str]:
    """The ``*.json`` file names directly inside ``folder`` of this package, sorted."""
    directory = files(__name__).joinpath(folder) if folder else files(__name__)
    return sorted(entry.name for entry in directory.iterdir() if entry.name.endswith(".json"))
