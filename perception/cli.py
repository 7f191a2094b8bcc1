"""``physmind perceive video.mp4 --camera camera.json -o observations.json [--debug-dir DIR]``."""

from __future__ import annotations

import argparse
import json
from pathlib import Path


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "perceive",
        help="track the objects of a tabletop video on the support plane",
        description="Classical (CPU, no learned weights) perception of a static-camera tabletop video: "
        "segment, track and lift every object to the plane z = 0 with colour, shape and material; "
        "writes an observations.json for `physmind fit`.",
    )
    parser.add_argument("video", type=Path, help="the video (mp4)")
    parser.add_argument("--camera", type=Path, required=True,
                        help="camera JSON: a bare camera (width height fx fy cx cy position rotation) or a ground_truth file")
    parser.add_argument("-o", "--output", type=Path, required=True, help="observations.json to write")
    parser.add_argument("--debug-dir", type=Path, help="write a contact sheet with masks, ids and attributes here")
    parser.add_argument("--quiet", action="store_true", help="no progress bars")
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    # Lazy: loaded only when this command runs, so `physmind --help` and the other commands start fast.
    from perception.pipeline import perceive_frames
    from perception.video import read_video
    from world.io import load_camera

    camera = load_camera(args.camera)
    frames, fps = read_video(args.video)
    observations, intermediates = perceive_frames(frames, camera, fps=fps, progress=not args.quiet)
    args.output.parent.mkdir(parents=True, exist_ok=True)
    args.output.write_text(json.dumps(observations.to_dict(), indent=1))
    print(f"{len(observations.objects)} objects -> {args.output}")
    for track in observations.objects:
        print(f"  object {track.id}: {track.color} {track.material} {track.shape.kind}, frames {int(track.frames[0])}-{int(track.frames[-1])}")
    if args.debug_dir is not None:
        # Lazy: loaded only when this command runs, so `physmind --help` and the other commands start fast.
        from perception.debug import write_debug

        for path in write_debug(args.debug_dir, frames, intermediates["lifted"], camera):
            print(f"debug: {path}")
    return 0
