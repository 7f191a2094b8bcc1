"""A real uvicorn process per test session (loopback, free port, own data dir), killed at the end."""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import httpx
import pytest

from physmind.local_server import stop_process
from world.io import world_to_dict

REPO = Path(__file__).resolve().parents[2]


def free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


@dataclass
class ServerProcess:
    url: str
    data_dir: Path
    process: subprocess.Popen
    log_path: Path
    api_key: str | None = None

    def client(self, **kwargs) -> httpx.Client:
        headers = {"Authorization": f"Bearer {self.api_key}"} if self.api_key else {}
        headers.update(kwargs.pop("headers", {}))
        return httpx.Client(base_url=self.url, timeout=60.0, headers=headers, **kwargs)

    def log_lines(self) -> list[str]:
        return self.log_path.read_text().splitlines()

    def stop(self) -> None:
        stop_process(self.process)


def start_server(data_dir: Path, log_path: Path, env_extra: dict[str, str] | None = None, timeout: float = 60.0,
                 extra_args: tuple[str, ...] = ()) -> ServerProcess:
    """``physmind serve`` on 127.0.0.1 and a free port (plus ``extra_args``); waits for /healthz."""
    port = free_port()
    env = {k: v for k, v in os.environ.items() if not k.startswith("PHYSMIND_")}
    env.update(env_extra or {})
    log = open(log_path, "ab")
    process = subprocess.Popen(
        [sys.executable, "-m", "physmind.cli", "serve", "--host", "127.0.0.1", "--port", str(port), "--data-dir", str(data_dir), *extra_args],
        cwd=REPO, env=env, stdout=log, stderr=subprocess.STDOUT,
    )
    log.close()
    server = ServerProcess(f"http://127.0.0.1:{port}", data_dir, process, log_path, (env_extra or {}).get("PHYSMIND_API_KEY"))
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if process.poll() is not None:
            raise RuntimeError(f"server exited with {process.returncode}:\n{log_path.read_text()[-3000:]}")
        try:
            if httpx.get(server.url + "/healthz", timeout=2.0).status_code == 200:
                return server
        except httpx.TransportError:
            pass
        time.sleep(0.1)
    server.stop()
    raise RuntimeError(f"server did not answer /healthz within {timeout} s:\n{log_path.read_text()[-3000:]}")


@pytest.fixture(scope="session")
def world_document(scene_builders) -> dict:
    return world_to_dict(scene_builders.six_object_world())


@pytest.fixture(scope="session")
def server(tmp_path_factory):
    directory = tmp_path_factory.mktemp("server")
    process = start_server(directory / "data", directory / "server.log")
    yield process
    process.stop()


@pytest.fixture(scope="session")
def client(server):
    with server.client() as http:
        yield http


@pytest.fixture(scope="session")
def world_id(client, world_document) -> str:
    response = client.post("/v1/worlds", json={"world": world_document})
    assert response.status_code == 201, response.text
    return response.json()["world_id"]


@pytest.fixture(scope="session")
def server_factory():
    """start_server(data_dir, log_path, env_extra) for tests that need their own process (stop it yourself)."""
    return start_server
