"""``make agent-demo``: a small open model answers questions through ``physmind ask --vlm``.

Builds a world from the first fixture scene's annotation (oracle tracks),
starts the local model server (SmolLM2-135M-Instruct on llama-cpp-python's
OpenAI-compatible server, physmind/model_server.py), asks two of the scene's
questions with ``physmind ask --vlm`` and stops the server. A 135M model is
far too small to reason about physics: the point is the loop (real HTTP,
real tool calls executed on the world), not the verdicts.

    python -m physmind.agent_demo [--out out/agent-demo] [--questions 2]
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

from physmind.model_server import MODEL_ALIAS, model_server

REPO = Path(__file__).resolve().parents[1]
FIXTURES = REPO / "tests" / "data" / "synth"
# A 135M model with ~1k tokens per request on shared cores: two tools and a small budget.
DEMO_TOOLS = "check_contact,list_events"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("out/agent-demo"))
    parser.add_argument("--questions", type=int, default=2)
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    world = args.out / "world.json"
    cli = [sys.executable, "-m", "physmind.cli"]
    if not world.is_file():
        subprocess.run([*cli, "build", str(FIXTURES / "annotations" / "annotation_00000.json"), "--camera",
                        str(FIXTURES / "ground_truth" / "scene_00000.json"), "-o", str(world)], check=True)
    video = json.loads((FIXTURES / "questions.json").read_text())[0]
    with model_server(log_path=args.out / "model_server.log") as base_url:
        print(f"model server: {base_url} ({MODEL_ALIAS})", flush=True)
        for question in video["questions"][: args.questions]:
            command = [*cli, "ask", "--world", str(world), question["question"], "--vlm", "--base-url", base_url,
                       "--model", MODEL_ALIAS, "--tools", DEMO_TOOLS, "--max-tool-calls", "3",
                       "--json", str(args.out / f"answer_{question['question_id']}.json")]
            for choice in question["choices"]:
                command += ["--choice", choice["choice"]]
            completed = subprocess.run(command, capture_output=True, text=True)
            print(completed.stdout or completed.stderr, flush=True)
            truth = [choice.get("answer") for choice in question["choices"]]
            print(f"  ground truth: {truth}\n", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
