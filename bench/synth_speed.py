"""Per-stage wall time of the scene generator (prints a table; no assertions).

    MUJOCO_GL=egl .venv/bin/python bench/synth_speed.py [--scenes 5] [--seed 0]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import synth  # noqa: F401  (MUJOCO_GL)
from synth.annotate import annotation_document, ground_truth_document, program_scene_from_ground_truth, proposals_document
from synth.generate import sample_accepted_scene
from synth.questions import scene_questions
from synth.render import render_scene, write_mp4
from synth.simulate import simulate


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--scenes", type=int, default=5)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    rows = []
    for index in range(args.scenes):
        t = {}
        start = time.perf_counter()
        spec, sim, attempts = sample_accepted_scene(args.seed, index)
        t["sample+sim"] = time.perf_counter() - start
        mark = time.perf_counter()
        cfs = {o.object_id: simulate(spec, removed=o.object_id) for o in spec.objects}
        t["counterfactual"] = time.perf_counter() - mark
        mark = time.perf_counter()
        rgb, instance = render_scene(spec, sim)
        t["render"] = time.perf_counter() - mark
        mark = time.perf_counter()
        write_mp4(__import__("pathlib").Path("/tmp/synth_speed.mp4"), rgb, spec.fps)
        t["encode"] = time.perf_counter() - mark
        mark = time.perf_counter()
        gt = ground_truth_document(spec, sim, cfs, args.seed, attempts)
        annotation_document(spec, sim)
        proposals_document(spec, instance)
        t["json+masks"] = time.perf_counter() - mark
        mark = time.perf_counter()
        scene_questions(program_scene_from_ground_truth(gt), np.random.default_rng(index))
        t["questions"] = time.perf_counter() - mark
        t["total"] = time.perf_counter() - start
        rows.append((index, len(spec.objects), attempts, t))
    stages = list(rows[0][3])
    print("scene objs tries " + " ".join(f"{s:>14}" for s in stages) + "  ms/frame(render)")
    for index, n, attempts, t in rows:
        print(f"{index:5d} {n:4d} {attempts:5d} " + " ".join(f"{t[s]:14.2f}" for s in stages) + f"  {1000 * t['render'] / 128:16.1f}")
    print("mean            " + " ".join(f"{np.mean([r[3][s] for r in rows]):14.2f}" for s in stages))


if __name__ == "__main__":
    main()
