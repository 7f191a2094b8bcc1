"""``physmind demo`` (what ``make demo`` runs): video -> world -> tool server -> three answered questions.

1. a scene: a fixture video of ``tests/data/synth`` below the current
   directory (a checkout; default scene 7), a dataset given with ``--data``,
   or ``--generate`` a fresh one with the MuJoCo scene generator (also the
   fallback when there are no fixtures and MuJoCo is installed, as after
   ``pip install 'physmind[synth]'``);
2. its world: perception + identification from the video when the perception
   pipeline is installed, else identification from the oracle tracks of the
   CLEVRER annotation (the output says which);
3. the tool server on a free loopback port (a subprocess), the world registered over HTTP;
4. one explanatory, one predictive and one counterfactual question asked
   through the HTTP tools by the offline program executor, printed with the
   evidence (facts + tool calls) and the dataset's ground truth;
5. the server stopped. Under 3 minutes on a 2-core machine.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from physmind.local_server import local_server
from planner.answer import render_answer
from planner.client import ToolClient
from planner.evaluate import load_dataset
from planner.executor import VideoExecutor, prediction_horizon_for, truth_of
from world.io import camera_from_dict

# Relative to the working directory: the fixtures live in a checkout, never in an installed package.
FIXTURES = Path("tests") / "data" / "synth"
DEFAULT_SCENE = 7
QUESTION_TYPES = ("explanatory", "predictive", "counterfactual")


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "demo", help="end-to-end demo: video -> world -> tool server -> answered questions",
        description="Build a world from a video, serve it, and answer an explanatory, a predictive and a "
                    "counterfactual question through the HTTP tools, with evidence and ground truth.")
    parser.add_argument("--scene", type=int, default=DEFAULT_SCENE, help=f"fixture scene index (default {DEFAULT_SCENE})")
    parser.add_argument("--data", type=Path, default=None,
                        help=f"dataset directory (default: {FIXTURES} of the checkout you run from)")
    parser.add_argument("--generate", action="store_true", help="generate a fresh scene with MuJoCo instead of a fixture")
    parser.add_argument("--seed", type=int, default=2024, help="seed of --generate (default 2024)")
    parser.add_argument("--source", choices=("video", "annotation"), default="video",
                        help="video: perception + identification (default); annotation: the oracle tracks")
    parser.add_argument("--out", type=Path, default=None, help="where to write world.json and answers.json (default: a temp dir)")
    parser.set_defaults(handler=run)


def _step(number: int, text: str) -> None:
    print(f"\n[{number}/5] {text}", flush=True)


def _generate(seed: int, out: Path) -> Path:
    command = [sys.executable, "-m", "physmind.cli", "synth", "--out", str(out), "--scenes", "1", "--seed", str(seed)]
    completed = subprocess.run(command, capture_output=True, text=True)
    if completed.returncode != 0:
        raise ValueError(f"scene generation failed: {completed.stderr.strip()[-500:]}")
    return out


def _mujoco_installed() -> bool:
    return importlib.util.find_spec("mujoco") is not None


def _dataset_source(args: argparse.Namespace) -> str:
    """``"generate"`` or ``"data"``: where the scene comes from, with the fallbacks of the module docstring."""
    if args.generate:
        return "generate"
    if args.data is not None:
        if not args.data.is_dir():
            raise ValueError(f"--data: no dataset directory at {args.data}")
        return "data"
    if FIXTURES.is_dir():
        return "data"
    if _mujoco_installed():
        print(f"no fixtures at ./{FIXTURES} (not a checkout): generating a scene with MuJoCo instead", flush=True)
        return "generate"
    raise ValueError(f"no fixtures at ./{FIXTURES} (run from a checkout); pass --data DIR (a CLEVRER-layout dataset) "
                     "or --generate a scene (needs: pip install 'physmind[synth]')")


def _pick_questions(questions: list[dict]) -> list[dict]:
    picked = []
    for kind in QUESTION_TYPES:
        match = next((q for q in questions if q.get("question_type") == kind), None)
        if match is not None:
            picked.append(match)
    return picked


def run(args: argparse.Namespace) -> int:
    # Lazy: perception and scipy take seconds to import; every other `physmind` command starts without them.
    from physmind.pipeline import build_world

    started = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="physmind-demo-") as scratch:
        out = args.out or Path(scratch)
        out.mkdir(parents=True, exist_ok=True)
        if _dataset_source(args) == "generate":
            _step(1, f"generating a scene with MuJoCo (seed {args.seed}) ...")
            data, scene = _generate(args.seed, out / "dataset"), 0
        else:
            data, scene = args.data or FIXTURES, args.scene
            _step(1, f"using scene {scene} of {data}")
        entries = {e.scene_index: e for e in load_dataset(data)}
        if scene not in entries:
            raise ValueError(f"--scene: {data} has no scene {scene}; it has {sorted(entries)}")
        entry = entries[scene]
        questions = _pick_questions(list(entry.questions))
        if not questions:
            raise ValueError(f"scene {scene} has no explanatory, predictive or counterfactual question")
        print(f"    video: {entry.video}")

        source = args.source
        camera = None if entry.camera_document is None else camera_from_dict(entry.camera_document)
        _step(2, f"building the world from the {'video (perception + identification)' if source == 'video' else 'annotation (oracle tracks) + identification'} ...")
        built = build_world(entry.video if source == "video" else entry.annotation, source, camera)  # type: ignore[arg-type]
        world_path = out / "world.json"
        world_path.write_text(json.dumps(built.world, indent=1))
        rmse = "-" if built.rmse is None else f"{built.rmse * 100:.1f} cm"
        print(f"    {len(built.world['bodies'])} bodies, fit rmse {rmse}, {built.seconds:.1f} s -> {world_path}")

        _step(3, "starting the tool server on a free loopback port ...")
        with local_server(out / "server-data") as url, ToolClient(url) as client:
            world = client.create_world(built.world, name=f"demo-scene-{scene}",
                                        horizon_frames=prediction_horizon_for(built.world))
            print(f"    {url}  world {world.world_id}  ({len(client.tools())} tools at {url}/v1/tools)")
            _step(4, "asking one question of each type through HTTP")
            executor = VideoExecutor(world)
            results = []
            for question in questions:
                answer = executor.answer_text(question["question"], [c["choice"] for c in question["choices"]])
                truth = truth_of(question)
                print()
                print(render_answer(answer, world.calls, truth))
                right = sum(1 for v, t in zip(answer.verdicts, truth) if v == t)
                print(f"  => {right}/{len(truth)} options agree with the ground truth; {answer.seconds * 1000:.0f} ms")
                results.append({"question_id": question.get("question_id"), "truth": truth, **answer.to_dict(world.calls)})
            (out / "answers.json").write_text(json.dumps(results, indent=1))
            _step(5, "stopping the server")
        options = sum(len(r["truth"]) for r in results)
        agree = sum(1 for r in results for c, t in zip(r["choices"], r["truth"]) if c["verdict"] == t)
        print(f"\ndone in {time.perf_counter() - started:.1f} s: {agree}/{options} options agree with the ground truth "
              f"({len(world.calls)} tool calls){'' if args.out is None else f'; files in {out}'}")
    return 0
