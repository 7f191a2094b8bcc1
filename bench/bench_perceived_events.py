"""Where perceived positions go wrong, and which observed collisions identification finds from them.

    nice -n 10 .venv/bin/python -m bench.bench_perceived_events DATA [--scenes 0-9] [--cache DIR]

Per scene: perceive the video (perception.pipeline.perceive; with --cache the
Observations are kept as DIR/<scene>.json and reused), match tracks to objects
(bench.bench_attribution.match_tracks), then

* lifting error on the plane of every used sample (weight > 0, object in
  view) against MuJoCo's position, by situation: isolated; near (another
  object in view within NEAR_M on the plane); overlapping in the image
  (projected centres within OVERLAP_PX, not near); at the border (projected
  centre within BORDER_PX of the image edge); per true shape; per weight band;
* observed collisions: world.identify.segments.find_candidate_collisions on
  the perceived and on the oracle tracks (Observations.from_clevrer_annotation)
  against MuJoCo's collisions in the observed window (same pair, within
  TOLERANCE_FRAMES): recall and precision.

Use only development data (no evaluation seed): the tables choose what to fix.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from bench.bench_attribution import UNMATCHED_ID_OFFSET, Truth, match_tracks, relabel
from perception.pipeline import perceive
from world.camera import project
from world.identify.segments import find_candidate_collisions
from world.io import load_camera
from world.observations import Observations

NEAR_M = 0.5
OVERLAP_PX = 60
BORDER_PX = 40
TOLERANCE_FRAMES = 5  # as bench.metrics' observed-collision recall
BIG_ERROR_M = 0.05


def _scenes(text: str) -> list[int]:
    if "-" in text:
        low, high = text.split("-")
        return list(range(int(low), int(high) + 1))
    return [int(s) for s in text.split(",")]


def _perceived(root: Path, name: str, camera, cache: Path | None) -> Observations:
    path = cache / f"{name}.json" if cache else None
    if path is not None and path.exists():
        return Observations.from_dict(json.loads(path.read_text()))
    observations = perceive(root / "videos" / f"video_{name}.mp4", camera)
    if path is not None:
        path.write_text(json.dumps(observations.to_dict()))
    return observations


def lifting_samples(observations: Observations, truth: Truth, camera) -> list[dict]:
    """One row per used, in-view sample of a matched track: error (m), situation flags, shape, weight."""
    column = {object_id: k for k, object_id in enumerate(truth.ids)}
    frames_total = truth.observed_frames
    pixels = project(camera, truth.positions.reshape(-1, 3)).reshape(frames_total, -1, 2)
    rows = []
    for track in observations.objects:
        if track.id >= UNMATCHED_ID_OFFSET:
            continue
        k = column[track.id]
        for frame, position, weight in zip(track.frames, track.positions, track.weights):
            if weight <= 0 or frame >= frames_total or not truth.visible[frame, k]:
                continue
            others = truth.visible[frame].copy()
            others[k] = False
            ground = np.linalg.norm(truth.positions[frame, :, :2] - truth.positions[frame, k, :2], axis=1)
            image = np.linalg.norm(pixels[frame] - pixels[frame, k], axis=1)
            u, v = pixels[frame, k]
            rows.append({
                "error": float(np.linalg.norm(position[:2] - truth.positions[frame, k, :2])),
                "near": bool((ground[others] < NEAR_M).any()),
                "overlap": bool((image[others] < OVERLAP_PX).any()),
                "border": bool(min(u, v, camera.width - u, camera.height - v) < BORDER_PX),
                "shape": truth.attributes[track.id][2],
                "weight": float(weight),
            })
    return rows


def collision_counts(observations: Observations, truth: Truth) -> tuple[int, int, int, int]:
    """(true found, true, candidates that are true, candidates)."""
    candidates = find_candidate_collisions(observations)

    def same(c, a, b, f) -> bool:
        return set(c.bodies) == {a, b} and abs(c.frame - f) <= TOLERANCE_FRAMES

    found = sum(any(same(c, a, b, f) for c in candidates) for a, b, f in truth.collisions)
    right = sum(any(same(c, a, b, f) for a, b, f in truth.collisions) for c in candidates)
    return found, len(truth.collisions), right, len(candidates)


def error_table(rows: list[dict]) -> str:
    errors = np.array([r["error"] for r in rows])
    big_total = max(int(np.sum(errors > BIG_ERROR_M)), 1)
    flags = {key: np.array([r[key] for r in rows]) for key in ("near", "overlap", "border")}
    weights = np.array([r["weight"] for r in rows])
    shapes = np.array([r["shape"] for r in rows])
    groups = [
        ("all", np.ones(errors.size, bool)),
        ("isolated", ~flags["near"] & ~flags["overlap"] & ~flags["border"]),
        (f"near (< {NEAR_M} m)", flags["near"]),
        (f"overlap in image (< {OVERLAP_PX} px), not near", flags["overlap"] & ~flags["near"]),
        (f"border (< {BORDER_PX} px)", flags["border"]),
        *[(shape, shapes == shape) for shape in ("sphere", "cube", "cylinder")],
        ("weight < 0.35", weights < 0.35),
        ("0.35 <= weight < 0.65", (weights >= 0.35) & (weights < 0.65)),
        ("weight >= 0.65", weights >= 0.65),
    ]
    lines = ["| samples | n | median (cm) | p95 (cm) | share > 5 cm | share of all > 5 cm errors |", "|---|---:|---:|---:|---:|---:|"]
    for label, mask in groups:
        if mask.any():
            e = errors[mask]
            lines.append(f"| {label} | {e.size} | {100 * np.median(e):.2f} | {100 * np.percentile(e, 95):.2f} | "
                         f"{np.mean(e > BIG_ERROR_M):.3f} | {np.sum(e > BIG_ERROR_M) / big_total:.2f} |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("data", type=Path, help="dataset written by physmind synth (development data only)")
    parser.add_argument("--scenes", default="0-9", help="scene indices: 0-9 or 0,3,5")
    parser.add_argument("--cache", type=Path, default=None, help="keep / reuse perceived Observations here (<scene>.json)")
    args = parser.parse_args(argv)
    if args.cache:
        args.cache.mkdir(parents=True, exist_ok=True)
    rows: list[dict] = []
    perceived_counts, oracle_counts = np.zeros(4, int), np.zeros(4, int)
    for index in _scenes(args.scenes):
        name = f"{index:05d}"
        truth_path = args.data / "ground_truth" / f"scene_{name}.json"
        truth = Truth(json.loads(truth_path.read_text()))
        camera = load_camera(truth_path)
        raw = _perceived(args.data, name, camera, args.cache)
        perceived = relabel(raw, match_tracks(raw, truth))
        oracle = Observations.from_clevrer_annotation(args.data / "annotations" / f"annotation_{name}.json", camera=camera)
        rows += lifting_samples(perceived, truth, camera)
        perceived_counts += collision_counts(perceived, truth)
        oracle_counts += collision_counts(oracle, truth)
        print(f"scene {index}: {len(raw.objects)} tracks, {len(truth.ids)} objects", flush=True)
    print(f"\nLifting error on the plane ({args.data.name}, scenes {args.scenes})\n")
    print(error_table(rows))
    print("\nObserved collisions from world.identify.segments.find_candidate_collisions\n")
    print("| tracks | recall | precision |\n|---|---:|---:|")
    for label, (found, actual, right, predicted) in (("perceived", perceived_counts), ("oracle", oracle_counts)):
        print(f"| {label} | {found / max(actual, 1):.3f} ({found}/{actual}) | {right / max(predicted, 1):.3f} ({right}/{predicted}) |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
