"""The wheel as a user gets it: built, installed without -e into a fresh venv, run outside the checkout.

Runs the same steps as the Docker image (``docker/install.sh``). Fails when
the wheel misses a runtime file (e.g. the schemas: ``physmind serve`` then
exits at start-up), ships bench/ or tests/, or a command looks for files of
the checkout.
"""

from __future__ import annotations

import json
import os
import socket
import subprocess
import sys
import time
import tomllib
from pathlib import Path

import httpx
import pytest

from schemas import schema_names

REPO = Path(__file__).resolve().parents[1]
INSTALL = REPO / "docker" / "install.sh"
ANNOTATION = REPO / "tests" / "data" / "synth" / "annotations" / "annotation_00001.json"


def _free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


def _run(command: list[str], cwd: Path, env: dict[str, str], timeout: float = 300) -> subprocess.CompletedProcess:
    completed = subprocess.run(command, cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout)
    assert completed.returncode == 0, f"{' '.join(command)}\n{completed.stdout[-2000:]}\n{completed.stderr[-3000:]}"
    return completed


@pytest.fixture(scope="module")
def installed(tmp_path_factory) -> tuple[Path, Path, dict[str, str]]:
    """(venv, a working directory outside the checkout, environment) after the Dockerfile's install steps."""
    root = tmp_path_factory.mktemp("packaging")
    venv, dist, outside = root / "venv", root / "dist", root / "outside"
    outside.mkdir()
    # Nothing of the checkout may leak in: no PYTHONPATH, no inherited venv, no API key.
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV", "PHYSMIND_API_KEY")}
    env["PYTHON"] = sys.executable
    _run(["sh", str(INSTALL), "wheel", str(REPO), str(dist)], outside, env)
    wheels = sorted(dist.glob("physmind-*.whl"))
    assert len(wheels) == 1, wheels
    _run(["sh", str(INSTALL), "deps", str(venv), str(REPO)], outside, env)
    _run(["sh", str(INSTALL), "app", str(venv), str(wheels[0])], outside, env)
    return venv, outside, env


@pytest.mark.slow
def test_wheel_ships_runtime_packages_and_schemas_only(installed):
    venv, outside, env = installed
    listing = _run([str(venv / "bin" / "pip"), "show", "-f", "physmind"], outside, env).stdout
    files = [line.strip() for line in listing.splitlines() if line.startswith("  ")]
    top_level = {name.split("/")[0] for name in files if "/" in name and not name.startswith("..")}
    assert not {"bench", "tests", "docker", "docs"} & top_level, sorted(top_level)
    assert {"physmind", "world", "tools", "server", "schemas"} <= top_level, sorted(top_level)
    shipped_tool_schemas = {Path(name).name for name in files if name.startswith("schemas/tools/")}
    assert shipped_tool_schemas == set(schema_names("tools")), "the wheel's tool schemas differ from the checkout's"
    # Imports resolve to the venv, not to the checkout.
    where = _run([str(venv / "bin" / "python"), "-c", "import server, schemas; print(server.__file__); print(schemas.__file__)"],
                 outside, env).stdout.split()
    assert all(str(venv) in path for path in where), where


@pytest.mark.slow
def test_installed_cli_version_fit_and_demo_without_fixtures(installed):
    venv, outside, env = installed
    physmind = str(venv / "bin" / "physmind")
    version = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]["version"]
    assert _run([physmind, "--version"], outside, env).stdout.strip() == f"physmind {version}"

    _run([physmind, "fit", str(ANNOTATION), "--no-joint", "-o", "world.json"], outside, env)
    world = json.loads((outside / "world.json").read_text())
    assert world["bodies"], "fit wrote a world without bodies"

    # No fixtures outside a checkout and no MuJoCo in the runtime install: one line, exit 2, the two ways out.
    demo = subprocess.run([physmind, "demo"], cwd=outside, env=env, capture_output=True, text=True, timeout=120)
    assert demo.returncode == 2, demo.stdout + demo.stderr
    lines = demo.stderr.strip().splitlines()
    assert len(lines) == 1 and "--data" in lines[0] and "--generate" in lines[0], demo.stderr
    assert "site-packages" not in demo.stderr


@pytest.mark.slow
def test_installed_server_lists_every_tool(installed):
    venv, outside, env = installed
    port = _free_port()
    log_path = outside / "server.log"
    with open(log_path, "wb") as log:
        server = subprocess.Popen([str(venv / "bin" / "physmind"), "serve", "--port", str(port), "--data-dir", str(outside / "data")],
                                  cwd=outside, env=env, stdout=log, stderr=subprocess.STDOUT)
    try:
        url = f"http://127.0.0.1:{port}"
        deadline = time.monotonic() + 60
        while True:
            assert server.poll() is None, f"physmind serve exited with {server.returncode}:\n{log_path.read_text()[-3000:]}"
            try:
                if httpx.get(url + "/healthz", timeout=2).status_code == 200:
                    break
            except httpx.TransportError:
                pass
            assert time.monotonic() < deadline, f"no /healthz within 60 s:\n{log_path.read_text()[-3000:]}"
            time.sleep(0.2)
        response = httpx.get(url + "/v1/tools", timeout=10)
        assert response.status_code == 200, response.text
        listed = {tool["function"]["name"] for tool in response.json()["tools"]}
        # Every tool of the checkout has an argument schema; the installed server lists each of them.
        declared = {name.removesuffix(".args.json") for name in schema_names("tools") if name.endswith(".args.json")}
        assert len(declared) >= 9 and listed == declared, (sorted(listed), sorted(declared))
    finally:
        server.terminate()
        server.wait(timeout=15)
