"""Grey objects on a floor of their own paint: how perception places and shapes objects whose tops pass for floor.

Usage:
  MUJOCO_GL=egl python -m bench.bench_grey_floor [--seed S] [--scenes N]

Draws N scenes of the held-out look family (synth.generate.scene_draws: their lights, cameras, compression),
paints every object grey and the floor flat with the grey paint's own albedo, so that a top face, lit as the
floor is, looks like the floor; simulates and renders them with MuJoCo, encodes h264 and perceives them. Each
track of at least 10 observed frames follows the object it is nearest to on average (when nearer than 0.3 m).
Prints per true shape: objects followed, the share whose median planar error over the track is within 3 cm,
the share read as their shape, and the wrong shapes. The condition of
tests/perception/test_perception_floor_like_tops.py, as figures (docs/benchmarks.md, twenty-first round).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from collections import Counter
from dataclasses import replace
from pathlib import Path

import numpy as np
from tqdm import tqdm

from perception.pipeline import perceive_frames
from perception.video import read_video
from synth.generate import scene_draws
from synth.render import render_scene, write_mp4
from synth.simulate import simulate
from world.types import CLEVR_PALETTE_RGB, SHAPE_KINDS

MATCH_M = 0.3  # a track follows the object it is nearest to on average, when nearer than this
MIN_TRACK_FRAMES = 10
NEAR_M = 0.03


def grey_scene(seed: int, index: int):
    """The first draw of (seed, index) in a held-out look, every object grey on a flat floor of the grey paint."""
    spec = next(scene_draws(seed, index, "heldout")[2])
    grey = CLEVR_PALETTE_RGB["gray"][0] / 255.0
    floor = replace(spec.look.floor, texture="flat", rgb=(grey,) * 3, rgb2=(grey,) * 3)
    return replace(spec, look=replace(spec.look, floor=floor), objects=tuple(replace(o, color="gray") for o in spec.objects))


def followed_objects(spec, sim, observations) -> list[tuple[str, str, float]]:
    """(true shape, perceived shape, median planar error m) of each track that follows an object."""
    rows = []
    for track in observations.objects:
        seen = track.frames[track.observed]
        if len(seen) < MIN_TRACK_FRAMES:
            continue
        errors = [np.linalg.norm(track.positions[track.observed, :2] - sim.positions[seen, k, :2], axis=1) for k in range(len(sim.object_ids))]
        k = int(np.argmin([e.mean() for e in errors]))
        if errors[k].mean() <= MATCH_M:
            rows.append((spec.objects[k].shape, track.shape.kind, float(np.median(errors[k]))))
    return rows


def perceived_rows(seed: int, index: int, directory: Path) -> list[tuple[str, str, float]]:
    """followed_objects of grey_scene(seed, index), simulated, rendered, encoded (into ``directory``) and perceived."""
    spec = grey_scene(seed, index)
    sim = simulate(spec, horizon_frames=spec.observed_frames)
    rgb, _ = render_scene(spec, sim)
    path = Path(directory) / f"grey_{seed}_{index}.mp4"
    write_mp4(path, rgb, spec.fps, spec.look.crf)
    frames, fps = read_video(path)
    observations, _ = perceive_frames(frames, spec.camera, fps=fps)
    return followed_objects(spec, sim, observations)


def table(rows: list[tuple[str, str, float]]) -> str:
    lines = [f"{'true shape':<10} {'objects':>7} {'within 3 cm':>11} {'shape right':>11}  wrong shapes"]
    for kind in (*SHAPE_KINDS, "all"):
        part = [r for r in rows if kind in ("all", r[0])]
        if not part:
            continue
        near = np.mean([e <= NEAR_M for _, _, e in part])
        right = np.mean([t == p for t, p, _ in part])
        wrong = Counter(f"{t}->{p}" for t, p, _ in part if t != p)
        lines.append(f"{kind:<10} {len(part):>7} {near:>11.3f} {right:>11.3f}  {', '.join(f'{k} {v}' for k, v in sorted(wrong.items())) or '-'}")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=902283)
    parser.add_argument("--scenes", type=int, default=8)
    args = parser.parse_args(argv)
    if args.scenes < 1:
        print("bench_grey_floor: --scenes must be at least 1", file=sys.stderr)
        return 2
    rows = []
    with tempfile.TemporaryDirectory() as scratch:
        for index in tqdm(range(args.scenes), desc="grey scenes", unit="scene"):
            rows += perceived_rows(args.seed, index, Path(scratch))
    print(f"# grey objects on a floor of their own paint, seed {args.seed}, {args.scenes} scenes")
    print(table(rows))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
