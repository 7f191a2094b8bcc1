"""Why the fitted world's edited replays miss counterfactual collisions: each miss by cause.

For every removable object of a scene and every pair that MuJoCo's re-simulation without it makes collide in
the video (ground truth ``counterfactual``) while the fitted world's replay without it does not (the pair's
collision set, as bench_identify's counterfactual F1 scores it), the first cause that applies:

1. ``not in world``: a body of the pair is not in the fitted world (never observed);
2. ``factual replay off``: the world's *factual* replay already puts a body of the pair more than
   OFF_METRES from MuJoCo's factual position at the frame of the counterfactual collision (the fit does
   not know where that body is then: out of view, not yet entered, or a missed interaction);
3. ``struck by the removed``: a body of the pair collided with the removed object in MuJoCo's factual
   video before that frame (without the removal's partner its course is the replay's extrapolation);
4. ``other``.

Each row also gives the larger of the two bodies' factual-replay errors at that frame (cm).

    MUJOCO_GL=egl python -m bench.bench_counterfactual_misses DATASET [--scenes N] [--workers 2]
        [--worlds DIR] [--save-worlds DIR] [--json rows.json]

DIR holds fitted worlds ``world_XXXXX.json`` (e.g. bench_qa's ``--cache C`` writes them to C/annotation);
without them each scene is fitted from its oracle tracks.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from bench.metrics import GroundTruth, rollout_collisions
from bench.runner import failed_lines, median_cm, miss_report_main, scene_world
from world.observations import Observations
from world.rollout import simulate
from world.types import Edit

OFF_METRES = 0.10  # m: a factual replay this far from MuJoCo at the frame does not know where the body is
CAUSES = ("not in world", "factual replay off", "struck by the removed", "other")


def _scene_rows(task: tuple[Path, Path | None, Path | None]) -> list[dict]:
    annotation, worlds, save_worlds = task
    index = annotation.stem.split("_")[-1]
    truth = GroundTruth.load(annotation.parent.parent / "ground_truth" / f"scene_{index}.json")
    world = scene_world(annotation, Observations.from_clevrer_annotation(annotation, camera=truth.camera), worlds, save_worlds)
    horizon = truth.observed_frames
    base = simulate(world, (), horizon)
    world_columns = {body: k for k, body in enumerate(base.body_ids)}
    truth_columns = {body: k for k, body in enumerate(truth.object_ids)}

    def factual_error(body: int, frame: int) -> float:
        """m: the world's factual replay against MuJoCo's factual run at ``frame``."""
        return float(np.linalg.norm(base.positions[frame, world_columns[body], :2] - truth.positions[frame, truth_columns[body], :2]))

    rows = []
    for removed, actual in sorted(truth.counterfactual.items()):
        if removed not in world_columns:
            continue
        replay = simulate(world, (Edit("remove_object", removed),), horizon)
        replayed = {pair for pair, _ in rollout_collisions(replay)}
        missed: dict[tuple[int, int], int] = {}
        for pair, frame in actual:
            if frame < horizon and pair not in replayed:
                missed.setdefault(pair, frame)  # the pair's first collision: the set is what is scored
        for pair, frame in sorted(missed.items()):
            if any(b not in world_columns for b in pair):
                name, error = CAUSES[0], float("nan")
            else:
                error = max(factual_error(b, frame) for b in pair)
                struck = any(tuple(sorted((b, removed))) == p and f < frame for b in pair for p, f in truth.collisions)
                name = CAUSES[1] if error > OFF_METRES else CAUSES[2] if struck else CAUSES[3]
            rows.append({"scene": int(index), "kind": "miss", "removed": removed, "pair": list(pair), "frame": int(frame),
                         "cause": name, "factual_error_m": error})
        rows.append({"scene": int(index), "kind": "counts", "removed": removed,
                     "mujoco": len({pair for pair, f in actual if f < horizon}), "world": len(replayed)})
    return rows


def table(rows: list[dict]) -> list[str]:
    """Per cause: misses and the median factual-replay error (cm) of the pair at the collision's frame."""
    counts = [r for r in rows if r["kind"] == "counts"]
    lines = [f"{len(counts)} removals: MuJoCo {sum(r['mujoco'] for r in counts)} colliding pairs, "
             f"the edited replays {sum(r['world'] for r in counts)}",
             f"  {'cause':<22} {'missed':>6} | {'factual error med (cm)':>22}"]
    for name in CAUSES:
        group = [r for r in rows if r.get("cause") == name]
        if not group:
            continue
        lines.append(f"  {name:<22} {len(group):>6} | {median_cm(group, 'factual_error_m', 22)}")
    return lines + failed_lines(rows)


def main(argv: list[str] | None = None) -> int:
    return miss_report_main(argv, __doc__.split("\n\n")[0], _scene_rows, table, workers=2)


if __name__ == "__main__":
    raise SystemExit(main())
