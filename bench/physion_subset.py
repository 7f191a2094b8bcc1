"""Trials of one Physion category, without video (for property diagnoses; `physmind synth --suite physion` makes all five).

Trial k is the one ``physmind synth --suite physion --seed S --scenes N`` makes as
trial k of that category (same index, same draw), so a subset of an earlier
benchmark can be regenerated without its videos.

Usage:
    python -m bench.physion_subset --category bounce_wall --seed 2026 --scenes 40 --out DIR
"""

from __future__ import annotations

import argparse
from pathlib import Path

from tqdm import tqdm

from synth.physion.generate import generate_trial, write_trials
from synth.physion.spec import CATEGORIES


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--category", choices=CATEGORIES, required=True)
    parser.add_argument("--seed", type=int, required=True)
    parser.add_argument("--scenes", type=int, required=True, help="trials (the per-category count of the full data set)")
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args()
    entries = [generate_trial(args.out, args.seed, args.category, k, args.scenes, video=False)[0]
               for k in tqdm(range(args.scenes), desc=args.category, unit="trial")]
    write_trials(args.out, entries)


if __name__ == "__main__":
    main()
