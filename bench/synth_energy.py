"""Collisions that gain kinetic energy in a generated dataset's ground truth (prints a table; no assertions).

An impact of two rigid bodies with restitution below 1 can only lose kinetic energy; a collision whose two
bodies leave with more than they brought is an artefact of the simulator's contact detection (synth-2 data,
MuJoCo's native CCD: cylinder-cube impacts, docs/benchmarks.md "Issue 13, ninth round"). Counted over the
*isolated* collisions: neither body in another collision within ISOLATION_FRAMES, and not launched within
that window (a launch adds energy on purpose). Kinetic energy of planar translation (J) from the ground
truth's positions, differenced over WINDOW_FRAMES just before and just after the collision's frame.

    .venv/bin/python -m bench.synth_energy DATASET [DATASET ...]
"""

from __future__ import annotations

import argparse
import json
import sys
from collections import Counter
from pathlib import Path

import numpy as np

ISOLATION_FRAMES = 6
WINDOW_FRAMES = 3
GAIN = 1.05  # after / before: more than 5 % gained counts as a gain


def collision_energy_ratios(document: dict) -> list[tuple[str, float]]:
    """(shape pair "a-b" sorted, kinetic energy after / before) per isolated collision of one ground truth."""
    fps = float(document["fps"])
    objects = {o["object_id"]: o for o in document["objects"]}
    path = {o["object_id"]: np.asarray(o["location"], dtype=float)[:, :2] for o in document["trajectory"]["objects"]}
    collisions = [e for e in document["events"] if e["kind"] == "collision"]
    ratios = []
    for event in collisions:
        frame, bodies = int(event["frame_id"]), tuple(event["object_ids"])
        others = [e for e in collisions if e is not event and set(e["object_ids"]) & set(bodies)]
        if any(abs(int(e["frame_id"]) - frame) <= ISOLATION_FRAMES for e in others):
            continue
        if any(0 < objects[b]["launch_frame"] and abs(objects[b]["launch_frame"] - frame) <= ISOLATION_FRAMES for b in bodies):
            continue
        before, after = frame - 1 - WINDOW_FRAMES, frame + 2
        if before < 0 or after + WINDOW_FRAMES >= len(path[bodies[0]]):
            continue

        def energy(start: int) -> float:
            return sum(0.5 * objects[b]["mass"] * float(np.sum(((path[b][start + WINDOW_FRAMES] - path[b][start]) * fps / WINDOW_FRAMES) ** 2))
                       for b in bodies)

        brought = energy(before)
        if brought > 1e-6:
            ratios.append(("-".join(sorted(objects[b]["shape"] for b in bodies)), energy(after) / brought))
    return ratios


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("datasets", nargs="+", type=Path, help="directories with ground_truth/scene_*.json")
    args = parser.parse_args(argv)
    for dataset in args.datasets:
        files = sorted((dataset / "ground_truth").glob("scene_*.json"))
        if not files:
            print(f"synth_energy: no ground_truth/scene_*.json in {dataset}", file=sys.stderr)
            return 2
        counts, gains, worst = Counter(), Counter(), {}
        versions = set()
        for file in files:
            document = json.loads(file.read_text())
            versions.add(document.get("generator", {}).get("version", "?"))
            for pair, ratio in collision_energy_ratios(document):
                counts[pair] += 1
                gains[pair] += ratio > GAIN
                worst[pair] = max(worst.get(pair, 0.0), ratio)
        print(f"# {dataset} ({len(files)} scenes, generator {', '.join(sorted(versions))}): isolated collisions "
              f"whose bodies leave with > {GAIN:g}x the kinetic energy they brought")
        print(f"{'shapes':<18} {'collisions':>10} {'gain energy':>11} {'worst after/before':>18}")
        for pair in sorted(counts):
            print(f"{pair:<18} {counts[pair]:>10} {gains[pair]:>11} {worst[pair]:>18.2f}")
        print(f"{'all':<18} {sum(counts.values()):>10} {sum(gains.values()):>11}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
