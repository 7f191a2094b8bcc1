"""``physmind build``, ``physmind ask`` and ``physmind eval``: the commands that wire several stages.

    physmind build video.mp4 --camera camera.json -o world.json
    physmind build annotation_00000.json --camera scene_00000.json -o world.json   (oracle tracks)
    physmind ask --world world.json "Which event will happen next?" --choice "The red cube collides with the sphere" ...
    physmind ask --server http://127.0.0.1:8000 --world-id w-... "..." --choice ... [--vlm --base-url ... --model ...]
    physmind eval DATASET_DIR [--workers N] [--dask local|tcp://HOST:8786] [--source annotation|video] [--mode execute|trajectory_only] [-o report.json]
"""

from __future__ import annotations

import argparse
import base64
import contextlib
import json
import sys
import time
from pathlib import Path
from typing import Any, Iterator

from perception.debug import png_bytes
from perception.video import read_video
from physmind.errors import CliError
from physmind.executors import add_dask_argument, check_dask_address
from physmind.local_server import local_server
from planner.answer import refuse_false_premise, render_answer
from planner.client import ToolClient
from planner.evaluate import evaluate, format_table, load_dataset
from planner.grounding import objects_from_summary
from planner.parser import question_guide
from planner.executor import ExecutorConfig, VideoExecutor, prediction_horizon_for
from planner.vlm import ChatClient, VlmConfig, VlmError, answer_with_vlm
from world.identify.materials import REVISION_FLAG
from world.io import load_camera


def register(subparsers: Any) -> None:
    """``physmind build``, ``ask`` and ``eval``."""
    register_build(subparsers)
    register_ask(subparsers)
    register_eval(subparsers)


def register_build(subparsers: Any) -> None:
    parser = subparsers.add_parser(
        "build", help="build an executable world from a video (perception + identification)",
        description="Video (or a CLEVRER annotation with oracle tracks) -> observations -> fitted world document.")
    parser.add_argument("input", type=Path, help="video.mp4, or annotation_XXXXX.json with --source annotation")
    parser.add_argument("--camera", type=Path, help="camera JSON (intrinsics + pose; a synth ground_truth file works)")
    parser.add_argument("--source", choices=("auto", "video", "annotation"), default="auto",
                        help="auto: .json -> annotation, anything else -> video")
    parser.add_argument("-o", "--output", type=Path, required=True, help="world.json to write")
    parser.set_defaults(handler=run_build)


def register_ask(subparsers: Any) -> None:
    parser = subparsers.add_parser(
        "ask", help="ask a multiple-choice question about a world",
        description="Answer a CLEVRER-style question with one verdict per choice, grounded in tool calls over HTTP. "
                    "Offline program executor by default; --vlm drives an OpenAI-compatible model instead.",
        epilog=question_guide(), formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("question", help="e.g. 'Which of the following will happen if the red cube is removed?'")
    parser.add_argument("--choice", action="append", default=[], required=True, help="one option (repeat)")
    where = parser.add_argument_group("world")
    where.add_argument("--world", type=Path, help="world.json (registered on the server; a local server is started without --server)")
    where.add_argument("--server", help="URL of a running tool server (PHYSMIND_API_KEY is sent when set)")
    where.add_argument("--world-id", help="a world already on --server")
    parser.add_argument("--mode", choices=("execute", "trajectory_only"), default="execute", help="trajectory_only: the no-execution ablation")
    parser.add_argument("--json", type=Path, help="also write the answer with its evidence as JSON")
    _vlm_arguments(parser)
    parser.set_defaults(handler=run_ask)


def _vlm_arguments(parser: argparse.ArgumentParser) -> None:
    group = parser.add_argument_group("VLM (OpenAI-compatible chat completions with function calling)")
    group.add_argument("--vlm", action="store_true", help="let a model plan the tool calls instead of the program executor")
    group.add_argument("--base-url", default=None, help="e.g. http://localhost:8001/v1 (default $OPENAI_BASE_URL)")
    group.add_argument("--model", default=None, help="model name (default $OPENAI_MODEL)")
    group.add_argument("--api-key", default=None, help="default $OPENAI_API_KEY (prefer the environment: arguments are visible in ps)")
    group.add_argument("--max-tool-calls", type=int, default=24, help="tool-call budget per question (default 24)")
    group.add_argument("--tools", default=None, help="comma-separated world tools to offer (default: all; small models may "
                                                     "only afford a few, e.g. check_contact,simulate_edit)")
    group.add_argument("--frames", type=int, default=0, help="attach N evenly spaced frames of --video to the first message "
                                                              "(default 0: text only)")
    group.add_argument("--video", type=Path, default=None, help="the video the world was built from (for --frames)")


def register_eval(subparsers: Any) -> None:
    parser = subparsers.add_parser(
        "eval", help="evaluate question answering on a CLEVRER-layout dataset",
        description="Build a world per video, ask every question through the tool server, and print per-option and "
                    "per-question accuracy per question type (the paper's Table 1 layout).")
    parser.add_argument("dataset", type=Path, metavar="DATASET_DIR", help="directory with questions.json, annotations/, videos/")
    parser.add_argument("--source", choices=("annotation", "video"), default="annotation",
                        help="annotation: oracle tracks (default); video: perception + identification")
    parser.add_argument("--mode", choices=("execute", "trajectory_only"), default="execute")
    parser.add_argument("--workers", type=int, default=1,
                        help="processes building worlds (or answering Physion trials) in parallel; with --dask local, "
                             "the LocalCluster's workers")
    add_dask_argument(parser, "the world builds (CLEVRER layout) or the trials (Physion layout)")
    parser.add_argument("--camera", type=Path, help="camera JSON for videos without ground_truth/scene_XXXXX.json")
    parser.add_argument("--limit", type=int, help="only the first N videos")
    parser.add_argument("--cache", type=Path, help="directory to reuse/store built worlds (world_XXXXX.json)")
    parser.add_argument("--server", help="URL of a running tool server (default: start one on a free loopback port)")
    parser.add_argument("-o", "--output", type=Path, default=Path("eval_report.json"), help="JSON report (default eval_report.json)")
    parser.set_defaults(handler=run_eval)


# -- handlers -----------------------------------------------------------------------------


def run_build(args: argparse.Namespace) -> int:
    # Lazy: perception and scipy take seconds to import; every other `physmind` command starts without them.
    from physmind.pipeline import build_world

    source = args.source
    if source == "auto":
        source = "annotation" if args.input.suffix.lower() == ".json" else "video"
    camera = load_camera(args.camera) if args.camera else None
    print(f"building a world from {source} {args.input} ...", flush=True)
    result = build_world(args.input, source, camera, progress=True)
    args.output.parent.mkdir(parents=True, exist_ok=True)
    args.output.write_text(json.dumps(result.world, indent=1))
    rmse = "-" if result.rmse is None else f"{result.rmse * 100:.1f} cm"
    print(f"world with {len(result.world['bodies'])} bodies -> {args.output} "
          f"(perception {result.perception_seconds:.1f} s, fit {result.fit_seconds:.1f} s, rmse {rmse})")
    for entry in result.world.get("provenance", {}).get("fit", {}).get("objects", []):
        for flag in entry.get("flags", []):
            if flag.startswith(REVISION_FLAG):
                print(f"  object {entry['id']}: {flag}")
    return 0


@contextlib.contextmanager
def _server_for(args: argparse.Namespace) -> Iterator[str]:
    if args.server:
        yield args.server
        return
    with local_server() as url:
        yield url


def frame_data_urls(video: Path | None, count: int) -> list[str]:
    """``count`` evenly spaced frames of ``video`` (first and last included) as PNG data URLs."""
    if count < 1:
        raise ValueError(f"--frames: expected >= 1, got {count}")
    if video is None:
        raise ValueError("--frames needs --video (the video the world was built from)")
    frames, _ = read_video(video)
    picks = sorted({round(k * (len(frames) - 1) / max(count - 1, 1)) for k in range(count)})
    return ["data:image/png;base64," + base64.b64encode(png_bytes(frames[k])).decode("ascii") for k in picks]


def run_ask(args: argparse.Namespace) -> int:
    if (args.frames or args.video) and not args.vlm:
        raise ValueError("--frames and --video are for --vlm (the program executor reads the world, not the video)")
    if args.world is None and args.world_id is None:
        raise ValueError("give --world world.json, or --server URL with --world-id")
    if args.world_id is not None and args.server is None:
        raise ValueError("--world-id needs --server")
    if args.world is not None and not args.world.is_file():
        raise FileNotFoundError(f"world file not found: {args.world}")
    document = None
    if args.world is not None:
        try:
            document = json.loads(args.world.read_text())
        except json.JSONDecodeError as error:
            raise ValueError(f"{args.world}: not valid JSON ({error.msg})") from None
        if not isinstance(document, dict) or not isinstance(document.get("observed_frames"), int):
            raise ValueError(f"{args.world}: not a world document (a JSON object as written by physmind fit/build)")
    with _server_for(args) as url, ToolClient(url) as client:
        if document is not None:
            world = client.create_world(document, name=args.world.stem, horizon_frames=prediction_horizon_for(document))
        else:
            world = client.world(args.world_id)
        if args.vlm:
            tool_names = tuple(name.strip() for name in args.tools.split(",") if name.strip()) if args.tools else None
            config = VlmConfig.from_args(args.base_url, args.model, args.api_key, max_tool_calls=args.max_tool_calls,
                                         tool_names=tool_names)
            images = frame_data_urls(args.video, args.frames) if args.frames else []
            with ChatClient(config) as chat:
                try:
                    answer = answer_with_vlm(chat, client, world, args.question, list(args.choice), config, images)
                except VlmError as error:
                    raise CliError(f"--vlm: {error}") from None
        else:
            answer = VideoExecutor(world, ExecutorConfig(mode=args.mode)).answer_text(args.question, list(args.choice))
        answer = refuse_false_premise(answer, objects_from_summary(world.call("get_world_summary")))
        print(render_answer(answer, world.calls))
        if args.json:
            args.json.parent.mkdir(parents=True, exist_ok=True)
            args.json.write_text(json.dumps({"world_id": world.world_id, "server": url, **answer.to_dict(world.calls)}, indent=1))
    return 0 if answer.error is None else 1


def run_eval(args: argparse.Namespace) -> int:
    # Lazy: perception and scipy take seconds to import; every other `physmind` command starts without them.
    from physmind.physion_eval import is_physion_dataset, run_physion_eval
    from physmind.pipeline import build_worlds

    if args.workers < 1:
        raise ValueError(f"--workers: expected >= 1, got {args.workers}")
    if args.dask is not None:
        check_dask_address(args.dask)
    if is_physion_dataset(args.dataset):  # Physion layout (trials.json): 3D contact prediction
        return run_physion_eval(args)

    if args.limit is not None and args.limit < 1:
        raise ValueError(f"--limit: expected >= 1, got {args.limit}")
    camera_document = None
    if args.camera:
        load_camera(args.camera)  # validates
        camera_document = json.loads(args.camera.read_text())
    entries = load_dataset(args.dataset, camera_document, args.limit)
    if not entries:
        raise ValueError(f"{args.dataset}/questions.json holds no videos")
    started = time.perf_counter()
    worlds, infos = build_worlds(entries, args.source, args.workers, args.cache, progress=True, dask=args.dask)
    build_seconds = time.perf_counter() - started
    with _server_for(args) as url, ToolClient(url) as client:
        result = evaluate(entries, worlds, client, ExecutorConfig(mode=args.mode), progress=True, build_info=infos)
    label = f"{'oracle tracks' if args.source == 'annotation' else 'video'} ({args.mode})"
    table = result.table()
    print(format_table({label: table}))
    failed_builds = {k: v["error"] for k, v in infos.items() if "error" in v}
    for index, error in sorted(failed_builds.items()):
        print(f"scene {index}: build failed: {error}", file=sys.stderr)
    report = result.to_dict(label, {"dataset": str(args.dataset), "source": args.source, "mode": args.mode,
                                    "videos": len(entries), "build_wall_seconds": round(build_seconds, 2)})
    args.output.parent.mkdir(parents=True, exist_ok=True)
    args.output.write_text(json.dumps(report, indent=1))
    cost = report["cost"]
    per_video = "-" if cost["build_seconds_per_video"] is None else f"{cost['build_seconds_per_video']:.1f} s"
    print(f"{len(entries)} videos, {cost['questions']} questions; build {per_video}/video, "
          f"answer {cost['answer_seconds_per_question'] * 1000:.0f} ms/question; report -> {args.output}")
    return 0
