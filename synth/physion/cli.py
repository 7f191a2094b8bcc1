"""``physmind synth --suite physion``: the handler behind the flag (registered by synth/cli.py).

    physmind synth --suite physion --out DIR --scenes N [--seed S] [--start-index K] [--workers W]

N trials per category (5 N in all), ``--start-index`` is the first k within
each category. Heavy imports (MuJoCo, PyAV) happen inside the handler.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from synth.cli import run_jobs


def _one_trial(job: tuple[str, int, str, int, int]):
    # Lazy: MuJoCo loads in the worker process, after MUJOCO_GL is set.
    from synth.physion.generate import generate_trial

    out, seed, category, k, per_category = job
    return generate_trial(Path(out), seed, category, k, per_category)


def run_physion(args: argparse.Namespace) -> int:
    if args.out is None:
        raise ValueError("--out: required (output directory)")
    if args.scenes is None or args.scenes < 1:
        raise ValueError(f"--scenes: expected an integer >= 1 (trials per category), got {args.scenes!r}")
    if args.start_index < 0 or args.workers < 1 or args.seed < 0:
        raise ValueError("--start-index and --seed must be >= 0, --workers >= 1")
    import synth.physion  # noqa: F401  (sets MUJOCO_GL before mujoco loads)

    from synth.physion.generate import summary_table, write_trials
    from synth.physion.spec import CATEGORIES

    args.out.mkdir(parents=True, exist_ok=True)
    per_category = args.start_index + args.scenes
    jobs = [(str(args.out), args.seed, category, k, per_category)
            for category in CATEGORIES for k in range(args.start_index, per_category)]
    results = run_jobs(_one_trial, jobs, args.workers, "synth physion", "trial")
    path = write_trials(args.out, [entry for entry, _ in results])
    print(summary_table([stats for _, stats in results]))
    print(f"wrote {len(results)} trials to {args.out} ({path})")
    return 0
