"""Where the error after the video comes from: the +3 s error split by cause.

For each object still moving at the last observed frame (the objects of
bench_identify's "+3 s" measure), the fitted world's planar error at +1/+2/+3 s
is attributed to one cause, the first that applies:

1. ``collision missed/invented``: a collision of the object after the video
   (up to +3 s) that MuJoCo has and the world has not, or the reverse
   (same pair within 5 frames, bench.metrics.match_events);
2. ``collision matched``: it collides after the video in both (the outgoing
   directions then depend on friction between objects and spin);
3. ``sphere, no collision``: a sphere on its own (rolling vs sliding);
4. ``spinning cube/cylinder``: a cube or cylinder turning faster than
   SPIN_RATE in MuJoCo at the last observed frame, no collision after;
5. ``plain slide``: the rest (friction and anchor state of a lone slide).

MuJoCo's angular velocities and collisions after the video come from
re-running the scene (``synth.generate.sample_accepted_scene`` with the
dataset's seed: the same scene) over the video plus FUTURE_SECONDS.

    MUJOCO_GL=egl python -m bench.bench_ahead_causes DATASET --seed S [--scenes N] [--workers 2]
        [--worlds DIR] [--save-worlds DIR] [--rolling-spheres]
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from bench.bench_identify import AHEAD_SECONDS, STILL_MOVING_SPEED
from bench.metrics import match_events, rollout_collisions
from bench.oracle_dataset import FUTURE_SECONDS
from bench.runner import dataset_annotations, print_and_save, run_with_progress
from synth.generate import sample_accepted_scene
from synth.simulate import simulate as mujoco_simulate
from world.identify.fit import FitConfig, identify
from world.io import world_from_dict, world_to_dict
from world.observations import Observations
from world.rollout import simulate

SPIN_RATE = 0.5  # rad/s about z: a cube or cylinder turning faster "spins"
CAUSES = ("collision missed/invented", "collision matched", "sphere, no collision",
          "spinning cube/cylinder", "plain slide")


def _object_rows(task: tuple[Path, int, Path | None, Path | None, bool]) -> list[dict]:
    annotation, seed, worlds, save_worlds, rolling = task
    index = int(annotation.stem.split("_")[-1])
    spec, _, _ = sample_accepted_scene(seed, index)
    last = spec.observed_frames - 1
    ahead = [int(round(a * spec.fps)) for a in AHEAD_SECONDS]
    horizon = spec.observed_frames + int(round(FUTURE_SECONDS * spec.fps)) + 1
    truth = mujoco_simulate(spec, horizon_frames=horizon)
    observations = Observations.from_clevrer_annotation(annotation, camera=spec.camera)
    cached = None if worlds is None else worlds / f"world_{index:05d}.json"
    if cached is not None and cached.is_file():
        world = world_from_dict(json.loads(cached.read_text()))
    else:
        world, _ = identify(observations, FitConfig(rolling_spheres=rolling))
        if save_worlds is not None:
            save_worlds.mkdir(parents=True, exist_ok=True)
            (save_worlds / f"world_{index:05d}.json").write_text(json.dumps(world_to_dict(world)))
    rollout = simulate(world, (), horizon)
    column = {body: k for k, body in enumerate(rollout.body_ids)}
    tracks = {t.id: t for t in observations.objects}
    shapes = {o.object_id: o.shape for o in spec.objects}
    window_end = last + ahead[-1]
    mujoco_after = [(c.bodies, c.frame) for c in truth.collisions if last < c.frame <= window_end]
    world_after = rollout_collisions(rollout, last + 1, window_end)
    rows = []
    for k, object_id in enumerate(truth.object_ids):
        track = tracks.get(object_id)
        speed = np.linalg.norm(truth.positions[last, k, :2] - truth.positions[last - 1, k, :2]) * spec.fps
        if track is None or speed <= STILL_MOVING_SPEED or object_id not in column or track.visible[: last + 1].sum() < 2:
            continue
        mine_truth = [c for c in mujoco_after if object_id in c[0]]
        mine_world = [c for c in world_after if object_id in c[0]]
        matched = match_events(mine_world, mine_truth)
        spin = abs(float(truth.angular_velocities[last, k, 2]))
        if matched.true_positives < max(len(mine_truth), len(mine_world)):
            cause = CAUSES[0]
        elif mine_truth:
            cause = CAUSES[1]
        elif shapes[object_id] == "sphere":
            cause = CAUSES[2]
        elif spin > SPIN_RATE:
            cause = CAUSES[3]
        else:
            cause = CAUSES[4]
        errors = [float(np.linalg.norm(rollout.positions[last + s, column[object_id], :2] - truth.positions[last + s, k, :2]))
                  for s in ahead]
        rows.append({"scene": index, "object": int(object_id), "shape": shapes[object_id], "cause": cause,
                     "spin": spin, "errors": errors, "mujoco_collisions": len(mine_truth), "world_collisions": len(mine_world)})
    return rows


def _safe(task) -> list[dict]:
    try:
        return _object_rows(task)
    except Exception as error:  # noqa: BLE001 - the table reports failures
        return [{"scene": task[0].stem, "error": f"{type(error).__name__}: {error}"}]


def table(rows: list[dict]) -> list[str]:
    """Per cause: objects, +1/+2/+3 s median / p90 (cm), share of the summed +3 s error."""
    good = [r for r in rows if "error" not in r]
    total = sum(r["errors"][-1] for r in good) or 1.0
    lines = [f"{'cause':<26} {'objects':>7} | " + " | ".join(f"+{a:.0f} s med   p90" for a in AHEAD_SECONDS)
             + " | share of +3 s error"]
    for cause in (*CAUSES, "all"):
        group = good if cause == "all" else [r for r in good if r["cause"] == cause]
        if not group:
            lines.append(f"{cause:<26} {0:>7} |")
            continue
        errors = np.array([r["errors"] for r in group]) * 100
        cells = " | ".join(f"{np.median(errors[:, j]):>8.1f} {np.percentile(errors[:, j], 90):>5.1f}" for j in range(len(AHEAD_SECONDS)))
        share = sum(r["errors"][-1] for r in group) / total * 100
        lines.append(f"{cause:<26} {len(group):>7} | {cells} | {share:>5.0f} %")
    failures = [r for r in rows if "error" in r]
    lines += [f"failed: scene {r['scene']}: {r['error']}" for r in failures]
    return lines


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("dataset", type=Path)
    parser.add_argument("--seed", type=int, required=True, help="the seed the dataset was generated with")
    parser.add_argument("--scenes", type=int, default=None)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--worlds", type=Path, default=None, help="read fitted worlds from here when present")
    parser.add_argument("--save-worlds", type=Path, default=None, help="write the fitted worlds here")
    parser.add_argument("--rolling-spheres", action="store_true", help="fit with FitConfig(rolling_spheres=True)")
    parser.add_argument("--json", type=Path, default=None, help="write the per-object rows here")
    args = parser.parse_args(argv)
    annotations = dataset_annotations(args.dataset, args.scenes)
    tasks = [(a, args.seed, args.worlds, args.save_worlds, args.rolling_spheres) for a in annotations]
    rows = [row for scene_rows in run_with_progress(_safe, tasks, args.workers, "scenes") for row in scene_rows]
    print_and_save(table(rows), rows, args.json)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
