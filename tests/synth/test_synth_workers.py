"""`physmind synth --workers N` leaves no process behind when it is killed (kill -9 runs no clean-up)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import pytest

from bench.proc_tree import descendants, is_alive


@pytest.mark.slow
def test_kill_9_of_synth_leaves_no_worker(tmp_path):
    command = [sys.executable, "-m", "physmind.cli", "synth", "--out", str(tmp_path / "data"), "--scenes", "4",
               "--seed", "4711", "--workers", "2"]
    process = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                               env={**os.environ, "MUJOCO_GL": "egl"})
    try:
        deadline = time.monotonic() + 60
        while len(descendants(process.pid)) < 2 and time.monotonic() < deadline:
            time.sleep(0.2)
        workers = descendants(process.pid)
        assert len(workers) >= 2, f"synth started no worker processes: {workers}"
        time.sleep(2.0)  # the workers are inside their first scene
        os.kill(process.pid, signal.SIGKILL)
        process.wait(10)
        deadline = time.monotonic() + 15
        while time.monotonic() < deadline and any(is_alive(pid) for pid in workers):
            time.sleep(0.2)
        survivors = [pid for pid in workers if is_alive(pid)]
        for pid in survivors:  # never leave them to the rest of the suite
            os.kill(pid, signal.SIGKILL)
        assert not survivors, "synth workers outlived the killed synth process"
    finally:
        if process.poll() is None:
            process.kill()
