"""Start the tool server as a subprocess on a free loopback port (demo, eval, ask).

The planner still talks to it over HTTP only; this module just runs
``python -m physmind.cli serve`` and waits for ``/healthz``.
"""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import tempfile
import time
from contextlib import contextmanager
from pathlib import Path
from typing import Iterator, Mapping, Sequence

import httpx


def free_port() -> int:
    """A TCP port on 127.0.0.1 that was free a moment ago."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


@contextmanager
def local_server(data_dir: Path | None = None, timeout: float = 60.0, log_path: Path | None = None) -> Iterator[str]:
    """Run ``physmind serve`` on 127.0.0.1:<free port>; yields its base URL, stops it on exit.

    data_dir: the registry directory (default: a fresh temporary directory,
    removed afterwards). The server's log goes to ``log_path`` (default: the
    data directory's ``server.log``). PHYSMIND_API_KEY is not passed on.

    Raises:
        RuntimeError: the server exited or did not answer /healthz within ``timeout`` s.
    """
    with tempfile.TemporaryDirectory(prefix="physmind-") as scratch:
        directory = Path(data_dir) if data_dir is not None else Path(scratch)
        directory.mkdir(parents=True, exist_ok=True)
        log_file = Path(log_path) if log_path is not None else directory / "server.log"
        port = free_port()
        env = {k: v for k, v in os.environ.items() if k != "PHYSMIND_API_KEY"}
        env.setdefault("PHYSMIND_LOG_LEVEL", "WARNING")
        command = [sys.executable, "-m", "physmind.cli", "serve", "--host", "127.0.0.1", "--port", str(port), "--data-dir", str(directory)]
        url = f"http://127.0.0.1:{port}"
        with loopback_process(command, env, log_file, url + "/healthz", "the tool server", timeout):
            yield url


@contextmanager
def loopback_process(command: Sequence[str], env: Mapping[str, str], log_file: Path, ready_url: str, what: str,
                     timeout: float, poll_seconds: float = 0.1) -> Iterator[subprocess.Popen]:
    """Run ``command`` (a server on a loopback port), wait until ``ready_url`` answers 200, stop it on exit.

    Its output goes to ``log_file``; ``what`` names it in errors.

    Raises:
        RuntimeError: the process exited, or ``ready_url`` did not answer within ``timeout`` s.
    """
    with open(log_file, "ab") as log:
        process = subprocess.Popen(list(command), stdout=log, stderr=subprocess.STDOUT, env=dict(env))
    try:
        deadline = time.monotonic() + timeout
        while True:
            if process.poll() is not None:
                tail = log_file.read_text(errors="replace")[-2000:]
                raise RuntimeError(f"{what} exited with code {process.returncode}:\n{tail}")
            try:
                if httpx.get(ready_url, timeout=2.0).status_code == 200:
                    break
            except httpx.TransportError:
                pass
            if time.monotonic() > deadline:
                raise RuntimeError(f"{what} did not answer {ready_url} within {timeout:.0f} s (log: {log_file})")
            time.sleep(poll_seconds)
        yield process
    finally:
        stop_process(process)


def stop_process(process: subprocess.Popen, grace_seconds: float = 15.0) -> None:
    """Stop a child process: SIGTERM, then SIGKILL if it has not exited within ``grace_seconds``."""
    if process.poll() is not None:
        return
    process.terminate()
    try:
        process.wait(timeout=grace_seconds)
    except subprocess.TimeoutExpired:
        process.kill()
        process.wait(timeout=5)
