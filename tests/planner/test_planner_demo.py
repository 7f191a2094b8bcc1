"""``physmind demo`` (what ``make demo`` runs) end to end: build, serve, ask three questions, stop."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import httpx
import pytest

REPO = Path(__file__).resolve().parents[2]


@pytest.mark.slow
def test_demo_answers_one_question_of_each_type(tmp_path):
    env = {k: v for k, v in os.environ.items() if not k.startswith("PHYSMIND_API_KEY")}
    env.setdefault("MUJOCO_GL", "egl")
    completed = subprocess.run([sys.executable, "-m", "physmind.cli", "demo", "--source", "annotation", "--out", str(tmp_path)],
                               capture_output=True, text=True, timeout=180, cwd=REPO, env=env)
    assert completed.returncode == 0, completed.stderr[-3000:]
    out = completed.stdout
    for step in ("[1/5]", "[2/5]", "[3/5]", "[4/5]", "[5/5]"):
        assert step in out
    for kind in ("Q (explanatory)", "Q (predictive)", "Q (counterfactual)"):
        assert kind in out
    assert "[truth:" in out and "tool calls:" in out and "because:" in out
    answers = json.loads((tmp_path / "answers.json").read_text())
    assert [a["question_type"] for a in answers] == ["explanatory", "predictive", "counterfactual"]
    assert all(a["tool_call_log"] and all(c["verdict"] in ("correct", "wrong") for c in a["choices"]) for a in answers)
    assert (tmp_path / "world.json").is_file()
    # The server subprocess is gone: its port no longer answers.
    url = next(line.split()[0] for line in out.splitlines() if line.strip().startswith("http://127.0.0.1:"))

    with pytest.raises(httpx.TransportError):
        httpx.get(url + "/healthz", timeout=2.0)
