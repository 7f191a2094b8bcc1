"""``physmind render``: overlay videos, top-down stills and replays of a world and its edits.

    physmind render world.json --video in.mp4 -o overlay.mp4          # the fitted world over the video
    physmind render world.json --video in.mp4 --frame 60 -o f60.png   # one overlay frame
    physmind render world.json -o topdown.png                         # factual rollout, top-down still
    physmind render world.json --edit '{"edit_type": "remove_object", "object_id": 3}' -o cf.mp4

Edits are simulate_edit arguments (the same JSON the tool takes); several ``--edit`` stack.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from dataclasses import replace

OUTPUT_KINDS = (".mp4", ".png")


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "render",
        help="draw a world: overlay video, top-down still or replay of factual vs edited",
        description="Draw a world document. With --video: the rollout drawn through the camera over the video "
                    "(continuation past its end on the dimmed last frame). Without: top-down panels of the factual "
                    "rollout and, with --edit, the edited one beside it, above an event timeline. "
                    "The output's suffix chooses a still (.png) or a video (.mp4, h264).",
    )
    parser.add_argument("world", type=Path, help="world.json (as written by physmind fit)")
    parser.add_argument("-o", "--output", type=Path, required=True, help="output file: .png (still) or .mp4 (video)")
    parser.add_argument("--video", type=Path, help="the source video to draw over (needs the world's camera)")
    parser.add_argument("--camera", type=Path, help="camera JSON to use instead of the world's own")
    parser.add_argument("--edit", action="append", default=[], metavar="JSON",
                        help="a simulate_edit argument object, e.g. '{\"edit_type\": \"remove_object\", \"object_id\": 3}'; repeat to stack")
    parser.add_argument("--frame", type=int, help="frame of a .png still (default: overlay middle of the video; top-down last frame with full trails)")
    parser.add_argument("--width", type=int, default=480, help="top-down panel width in pixels (default 480; height is 3/4 of it)")
    parser.set_defaults(handler=run)


def _edit_arguments(text: str, index: int) -> dict:
    try:
        arguments = json.loads(text)
    except json.JSONDecodeError as error:
        raise ValueError(f"--edit #{index + 1} is not valid JSON ({error.msg})") from None
    if not isinstance(arguments, dict):
        raise ValueError(f"--edit #{index + 1}: expected a JSON object of simulate_edit arguments")
    return arguments


def run(args: argparse.Namespace) -> int:
    # Lazy: the engine, Pillow and PyAV load only for `physmind render`.
    from tools.errors import ToolError
    from tools.registry import call_tool
    from tools.session import MemoryRolloutStore, WorldSession
    from world.io import load_camera, read_json_file, world_from_dict

    from render.compose import Overlay, comparison, png_bytes
    from render.video import encode_mp4, read_video

    suffix = args.output.suffix.lower()
    if suffix not in OUTPUT_KINDS:
        raise ValueError(f"-o {args.output}: the suffix must be one of {', '.join(OUTPUT_KINDS)}")
    if not 160 <= args.width <= 2000:
        raise ValueError(f"--width: expected 160..2000 pixels, got {args.width}")
    world = world_from_dict(read_json_file(args.world, "world file"))
    if args.camera is not None:
        world = replace(world, camera=load_camera(args.camera))
    edits = [_edit_arguments(text, i) for i, text in enumerate(args.edit)]

    started = time.perf_counter()
    session = WorldSession("render", world, MemoryRolloutStore())
    base = session.base_rollout()
    rollout = base
    for index, arguments in enumerate(edits):
        arguments = {**arguments, "trajectory_detail": "summary"}
        if rollout is not base:
            arguments.setdefault("based_on", rollout.id)
        try:
            result = call_tool("simulate_edit", session, arguments)
        except ToolError as error:
            raise ValueError(f"--edit #{index + 1}: {error}") from None
        rollout = session.rollout(result["rollout_id"], tool=None)

    if args.video is not None:
        video, _ = read_video(args.video)
        if args.frame is not None and not 0 <= args.frame < rollout.horizon_frames:
            raise ValueError(f"--frame: expected 0..{rollout.horizon_frames - 1}, got {args.frame}")
        if suffix == ".png":
            frame = args.frame if args.frame is not None else min(video.shape[0], rollout.horizon_frames) // 2
            data = png_bytes(Overlay(world, rollout, video).image(frame))
        else:
            print(f"render: drawing {rollout.horizon_frames} frames over {args.video} ...", file=sys.stderr)
            data = encode_mp4(Overlay(world, rollout, video).frames(), rollout.fps)
    else:
        board = comparison(world, base, None if rollout is base else rollout, args.width, args.width * 3 // 4)
        if args.frame is not None and not 0 <= args.frame < board.horizon_frames:
            raise ValueError(f"--frame: expected 0..{board.horizon_frames - 1}, got {args.frame}")
        if suffix == ".png":
            data = png_bytes(board.image(args.frame))
        else:
            print(f"render: drawing {board.horizon_frames} top-down frames ...", file=sys.stderr)
            data = encode_mp4(board.frames(), rollout.fps)
    args.output.parent.mkdir(parents=True, exist_ok=True)
    args.output.write_bytes(data)
    what = "overlay" if args.video is not None else ("factual vs edited" if rollout is not base else "factual")
    print(f"render: {what} -> {args.output} ({len(data) // 1024} KiB, {time.perf_counter() - started:.2f} s)")
    return 0
