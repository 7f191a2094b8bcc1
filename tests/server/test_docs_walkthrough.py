"""The curl walkthrough of docs/server.md runs as written: every call answers JSON, the script exits 0."""

from __future__ import annotations

import os
import re
import signal
import subprocess
from pathlib import Path

import pytest

from physmind.local_server import free_port

REPO = Path(__file__).resolve().parents[2]


def walkthrough_script() -> str:
    """The first ```bash block after the "## curl walkthrough" heading of docs/server.md."""
    text = (REPO / "docs" / "server.md").read_text()
    section = text[text.index("## curl walkthrough"):]
    return re.search(r"```bash\n(.*?)```", section, flags=re.S)[1]


@pytest.mark.slow
def test_server_docs_walkthrough_runs(tmp_path):
    script = walkthrough_script()
    assert "PORT=8000\n" in script and "/tmp/physmind-" in script
    script = script.replace("PORT=8000\n", f"PORT={free_port()}\n").replace("/tmp/physmind-", f"{tmp_path}/physmind-")
    # Fail on the first command that fails, including a response json.tool cannot read.
    script = "set -euo pipefail\n" + script
    env = {k: v for k, v in os.environ.items() if k != "PHYSMIND_API_KEY"}
    process = subprocess.Popen(["bash", "-c", script], cwd=REPO, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                               text=True, start_new_session=True)
    try:
        out, err = process.communicate(timeout=120)
    finally:
        # The script's background server survives a failed script: stop the whole process group.
        try:
            os.killpg(process.pid, signal.SIGTERM)
        except ProcessLookupError:
            pass
        process.wait(timeout=10)
    log = tmp_path / "physmind-server.log"
    assert process.returncode == 0, f"{err[-2000:]}\n--- stdout\n{out[-2000:]}\n--- server log\n{log.read_text()[-2000:] if log.exists() else ''}"
    for promised in ('"code": "invalid_arguments"', '"pointer": "/object_a"', '"pointer": "/object_b"',
                     "'red' is not of type 'integer'", '"code": "object_not_found"', '"status": "missing_frame"'):
        assert promised in out, promised
    assert log.stat().st_size > 0, "the server log is empty"
