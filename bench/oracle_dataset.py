"""A CLEVRER-layout dataset for the oracle-track benchmarks, without the video.

    MUJOCO_GL=egl .venv/bin/python -m bench.oracle_dataset --out DIR --scenes 100 --seed S [--workers 2]

Writes what ``physmind synth`` writes except the video and the masks:
``annotations/``, ``ground_truth/`` and ``questions.json`` (same sampler,
same MuJoCo simulation, same question generator, same seed -> same scenes),
plus ``future/scene_XXXXX.json``: MuJoCo's object positions up to
``FUTURE_SECONDS`` after the last observed frame (the generator's horizon
covers only ~2 s), for the +1/+2/+3 s prediction error of bench_identify.
Rendering costs ~45 s a scene on the shared 2-core machine; the oracle-track
benchmarks (bench_identify, bench_qa --skip-video) never read the video.
"""

from __future__ import annotations

import argparse
import sys
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

from synth.annotate import annotation_document, ground_truth_document
from synth.generate import _dump, questions_entry, sample_accepted_scene, write_questions
from synth.simulate import simulate

FUTURE_SECONDS = 3.0  # s after the last observed frame


def oracle_scene(out: Path, seed: int, index: int) -> dict:
    """Annotation + ground truth + questions of scene ``index`` (the questions.json entry)."""
    spec, sim, attempts = sample_accepted_scene(seed, index)
    counterfactuals = {o.object_id: simulate(spec, removed=o.object_id) for o in spec.objects}
    ground_truth = ground_truth_document(spec, sim, counterfactuals, seed, attempts)
    _dump(out / "annotations" / f"annotation_{index:05d}.json", annotation_document(spec, sim))
    _dump(out / "ground_truth" / f"scene_{index:05d}.json", ground_truth)
    future_frames = spec.observed_frames + int(round(FUTURE_SECONDS * spec.fps)) + 1
    longer = simulate(spec, horizon_frames=future_frames)
    _dump(out / "future" / f"scene_{index:05d}.json", {
        "fps": float(spec.fps), "observed_frames": int(spec.observed_frames),
        "object_ids": [int(o.object_id) for o in spec.objects],
        "positions": np.round(longer.positions, 5).tolist(),  # (T, N, 3) m, objects in object_ids order
    })
    # physmind synth's own question entry: only objects seen in the video are named.
    return questions_entry(ground_truth, seed, index)


def _job(job: tuple[str, int, int]) -> dict:
    out, seed, index = job
    return oracle_scene(Path(out), seed, index)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", required=True)
    parser.add_argument("--scenes", type=int, required=True)
    parser.add_argument("--seed", type=int, required=True)
    parser.add_argument("--workers", type=int, default=1)
    args = parser.parse_args(argv)
    out = Path(args.out)
    jobs = [(str(out), args.seed, k) for k in range(args.scenes)]
    entries = []
    with ProcessPoolExecutor(max_workers=max(1, args.workers)) as pool:
        for done, entry in enumerate(pool.map(_job, jobs), 1):
            entries.append(entry)
            print(f"\roracle_dataset: {done}/{len(jobs)} scenes", end="", file=sys.stderr, flush=True)
    print(file=sys.stderr)
    write_questions(out, entries)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
