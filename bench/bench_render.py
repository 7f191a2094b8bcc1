"""Render speed: overlay of a 128-frame video, top-down PNG and top-down replay.

    MUJOCO_GL=egl .venv/bin/physmind synth --out /tmp/render_bench --scenes 3 --seed 1616 --workers 1
    nice -n 10 .venv/bin/python -m bench.bench_render /tmp/render_bench

For each scene: fit the world from its annotation with the true camera (``physmind fit``'s path),
simulate the factual rollout (observed frames + 20 %) and one counterfactual (remove the first
object), then time, ``--repeats`` times each:

* decode: the source mp4 to RGB frames (PyAV), reported apart;
* overlay mp4: drawing every rollout frame over the video through the camera and encoding h264
  (frames past the video's end are drawn on its dimmed last frame);
* top-down PNG: factual vs edited side by side with the event timeline, as the server draws it;
* top-down mp4: the same as a replay.

Targets: overlay of a 128-frame video <= 5 s, top-down PNG <= 0.5 s on 2 cores.
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

from render.compose import Overlay, comparison, png_bytes
from render.video import encode_mp4, read_video
from world.identify.cli import load_observations
from world.identify.fit import FitConfig, identify
from world.rollout import default_horizon, simulate
from world.types import Edit


def _timed(function, repeats: int) -> tuple[float, object]:
    times, result = [], None
    for _ in range(repeats):
        started = time.perf_counter()
        result = function()
        times.append(time.perf_counter() - started)
    return statistics.median(times), result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("data", type=Path, help="a physmind synth output directory")
    parser.add_argument("--scenes", type=int, default=3)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    rows = []
    for annotation in sorted((args.data / "annotations").glob("annotation_*.json"))[: args.scenes]:
        index = annotation.stem.split("_")[-1]
        observations = load_observations(annotation, args.data / "ground_truth" / f"scene_{index}.json")
        world, _ = identify(observations, FitConfig())
        horizon = default_horizon(world)
        base = simulate(world, (), horizon_frames=horizon, rollout_id="base")
        edited = simulate(world, (Edit("remove_object", world.bodies[0].id),), horizon_frames=horizon, rollout_id="r-1")
        decode_s, (video, fps) = _timed(lambda: read_video(str(args.data / "videos" / f"video_{index}.mp4")), args.repeats)
        overlay_s, overlay = _timed(lambda: encode_mp4(Overlay(world, base, video).frames(), base.fps), args.repeats)
        png_s, png = _timed(lambda: png_bytes(comparison(world, base, edited).image()), args.repeats)
        replay_s, replay = _timed(lambda: encode_mp4(comparison(world, base, edited).frames(), base.fps), args.repeats)
        rows.append((index, len(world.bodies), video.shape[0], horizon, decode_s, overlay_s, png_s, replay_s,
                     len(overlay) // 1024, len(png) // 1024, len(replay) // 1024))
    print("| scene | bodies | video frames | rendered frames | decode s | overlay mp4 s | top-down PNG s | top-down mp4 s | overlay KiB | PNG KiB | replay KiB |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for row in rows:
        print("| {} | {} | {} | {} | {:.2f} | {:.2f} | {:.3f} | {:.2f} | {} | {} | {} |".format(*row))
    print(f"\nmedian over scenes (each the median of {args.repeats} runs): overlay mp4 {statistics.median(r[5] for r in rows):.2f} s "
          f"(target <= 5 s), top-down PNG {statistics.median(r[6] for r in rows):.3f} s (target <= 0.5 s), "
          f"top-down mp4 {statistics.median(r[7] for r in rows):.2f} s, decode {statistics.median(r[4] for r in rows):.2f} s")


if __name__ == "__main__":
    main()
