"""The import picture of docs/architecture.md, checked on the source: which package may import which.

world <- tools <- server; world <- perception; world <- planner; only the
composition root (physmind/) wires several stages together; synth/ (ground
truth) and bench/ may use anything. ``schemas`` is a data-only package every
package may read.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
ANYTHING = None
# package -> the packages of ours it may import (ANYTHING: no restriction).
ALLOWED: dict[str, set[str] | None] = {
    "schemas": set(),
    "render": {"world", "tools", "schemas"},
    "world": {"schemas"},
    "tools": {"world", "schemas"},
    "server": {"tools", "world", "schemas", "render"},
    "perception": {"world", "schemas"},
    "planner": {"world", "schemas"},
    "physmind": ANYTHING,
    "synth": ANYTHING,
    "bench": ANYTHING,
}
# Inside world/, the fitter is a consumer of the engine and its types, never the other way round.
IDENTIFY = "world.identify"


def _packages() -> list[str]:
    return sorted(p.name for p in REPO.iterdir() if (p / "__init__.py").is_file() and p.name != "tests")


def _imports(path: Path) -> set[str]:
    modules: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), filename=str(path))):
        if isinstance(node, ast.Import):
            modules.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            modules.add(node.module)
    return modules


def test_every_package_has_a_place_in_the_picture():
    unknown = set(_packages()) - set(ALLOWED)
    assert not unknown, f"packages missing from the import picture (add them to ALLOWED and docs/architecture.md): {unknown}"


@pytest.mark.parametrize("package", [p for p in ALLOWED if ALLOWED[p] is not ANYTHING])
def test_imports_point_one_way(package):
    allowed = ALLOWED[package]
    ours = set(ALLOWED)
    offences = []
    for path in sorted((REPO / package).rglob("*.py")):
        for module in _imports(path):
            top = module.split(".")[0]
            if top in ours and top != package and top not in allowed:
                offences.append(f"{path.relative_to(REPO)} imports {module}")
            inside_identify = path.relative_to(REPO).parts[:2] == ("world", "identify")
            if module.startswith(IDENTIFY) and not inside_identify and package != "world":
                offences.append(f"{path.relative_to(REPO)} imports the fitter ({module})")
            if package == "world" and module.startswith(IDENTIFY) and not inside_identify:
                offences.append(f"{path.relative_to(REPO)}: the engine must not import the fitter ({module})")
    assert not offences, "\n".join(offences)
