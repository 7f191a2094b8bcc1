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


def observations_document(observations) -> dict:
    """The observations.json document (the layout of Observations.to_dict / from_dict), camera included.

    Written here because world.identify's to_dict needs world.io.camera_to_dict, which world.io lacks so far.
    """
    import math

    from perception.video import camera_to_mapping

    objects = []
    for track in observations.objects:
        shape = {"kind": track.shape.kind, "radius": track.shape.radius, "half_extent": track.shape.half_extent,
                 "half_height": track.shape.half_height}
        frames = [{"frame": int(f), "position": [float(v) for v in p], "yaw": None if math.isnan(y) else float(y),
                   "visible": bool(vis), "weight": float(w)}
                  for f, p, y, vis, w in zip(track.frames, track.positions, track.yaw, track.visible, track.weights)]
        objects.append({"id": int(track.id), "color": track.color, "material": track.material, "shape": shape, "frames": frames})
    return {"fps": float(observations.fps), "num_frames": int(observations.num_frames),
            "camera": camera_to_mapping(observations.camera) if observations.camera else None,
            "source": dict(observations.source), "objects": objects}


def run(args: argparse.Namespace) -> int:
    from perception.pipeline import perceive_frames
    from perception.video import load_camera, read_video

    camera = load_camera(args.camera)
    frames, fps = read_video(args.video)
    observations, intermediates = perceive_frames(frames, camera, fps=fps, progress=not args.quiet)
    args.output.parent.mkdir(parents=True, exist_ok=True)
    args.output.write_text(json.dumps(observations_document(observations), indent=1))
    print(f"{len(observations.objects)} objects -> {args.output}")
    for track in observations.objects:
        print(f"  object {track.id}: {track.color} {track.material} {track.shape.kind}, frames {int(track.frames[0])}-{int(track.frames[-1])}")
    if args.debug_dir is not None:
        from perception.debug import write_debug

        for path in write_debug(args.debug_dir, frames, intermediates["lifted"], camera):
            print(f"debug: {path}")
    return 0
