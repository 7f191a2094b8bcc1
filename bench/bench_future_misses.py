"""Why the fitted world misses future collisions: each miss and each invention by cause.

For every collision after the video (within the generator's horizon, the
events bench_identify's predictive F1 scores) that MuJoCo has and the fitted
world has not (a *miss*), and every one the world has and MuJoCo has not (an
*invention*), the first cause that applies:

1. ``never seen``: a body of the pair is never visible in the video (it
   enters after the video or stays out of view);
2. ``seen late``: a body is first seen in the last LATE_FRAMES frames;
3. ``history changed``: the world misses or invents an observed collision
   (in the video, bench.metrics.match_events) of one of the two bodies;
4. ``repeated touch``: the same pair collided shortly before (REPEAT_FRAMES) in
   the side with the event (a push, or a bounce back into contact);
5. ``timing``: the same pair collides in the other side within TIMING_FRAMES
   but beyond the 5-frame tolerance;
6. ``hit at rest``: a body of the pair is at rest at the last observed frame
   (MuJoCo speed below bench_identify.STILL_MOVING_SPEED);
7. ``near miss``: the pair's centre distance in the side without the event
   comes within NEAR_MISS metres of the contact distance of the side with it
   (+-TIMING_FRAMES frames);
8. ``far off``: the rest.

The same table for the collisions in the video (misses and inventions of
the fitted replay), causes 1, 2, 4, 5, 7, 8.

    MUJOCO_GL=egl python -m bench.bench_future_misses DATASET [--scenes N] [--workers 2]
        [--worlds DIR] [--save-worlds DIR] [--json rows.json]
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from bench.bench_identify import STILL_MOVING_SPEED
from bench.metrics import EVENT_TOLERANCE_FRAMES, GroundTruth, rollout_collisions, unmatched_events
from bench.runner import failed_lines, median_cm, miss_report_main, scene_world
from world.observations import Observations
from world.rollout import simulate

LATE_FRAMES = 10  # frames: first seen this close to the end = "seen late"
TIMING_FRAMES = 25  # frames: same pair this close (beyond the tolerance) = "timing"
NEAR_MISS = 0.05  # m
REPEAT_FRAMES = 40  # frames: the pair touched this shortly before in the side with the event = "repeated touch"
CAUSES = ("never seen", "seen late", "history changed", "repeated touch", "timing", "hit at rest", "near miss", "far off")


def _centre_distance(positions: np.ndarray, columns: dict, pair: tuple[int, int], frames: np.ndarray) -> np.ndarray:
    a, b = (positions[frames, columns[i], :2] for i in pair)
    return np.linalg.norm(a - b, axis=1)


def _scene_rows(task: tuple[Path, Path | None, Path | None]) -> list[dict]:
    annotation, worlds, save_worlds = task
    index = annotation.stem.split("_")[-1]
    truth = GroundTruth.load(annotation.parent.parent / "ground_truth" / f"scene_{index}.json")
    observations = Observations.from_clevrer_annotation(annotation, camera=truth.camera)
    world = scene_world(annotation, observations, worlds, save_worlds)
    horizon = truth.horizon_frames
    base = simulate(world, (), horizon)
    world_columns = {body: k for k, body in enumerate(base.body_ids)}
    truth_columns = {body: k for k, body in enumerate(truth.object_ids)}
    last = truth.observed_frames - 1
    first_seen = {t.id: (int(np.flatnonzero(t.visible)[0]) if t.visible.any() else None) for t in observations.objects}
    speed = {i: float(np.linalg.norm(truth.positions[last, k, :2] - truth.positions[last - 1, k, :2]) * world.fps)
             for i, k in truth_columns.items()}
    world_events = rollout_collisions(base)
    truth_events = list(truth.collisions)
    in_video = lambda events: [e for e in events if e[1] <= last]  # noqa: E731
    after = lambda events: [e for e in events if e[1] > last]  # noqa: E731
    observed_wrong = (unmatched_events(in_video(world_events), in_video(truth_events), EVENT_TOLERANCE_FRAMES)
                      + unmatched_events(in_video(truth_events), in_video(world_events), EVENT_TOLERANCE_FRAMES))
    history_bodies = {b for pair, _ in observed_wrong for b in pair}

    def cause(pair, frame, kind, window: str) -> tuple[str, float]:
        other = world_events if kind == "miss" else truth_events  # the side that lacks the event
        has_side, has_columns = (truth.positions, truth_columns) if kind == "miss" else (base.positions, world_columns)
        lacks_side, lacks_columns = (base.positions, world_columns) if kind == "miss" else (truth.positions, truth_columns)
        frames = np.arange(max(0, frame - TIMING_FRAMES), min(horizon, frame + TIMING_FRAMES + 1))
        gap = float("nan")
        if all(i in lacks_columns for i in pair) and all(i in has_columns for i in pair):
            contact = float(_centre_distance(has_side, has_columns, pair, np.array([frame]))[0])
            gap = float(np.min(_centre_distance(lacks_side, lacks_columns, pair, frames)) - contact)
        if any(first_seen.get(i) is None for i in pair) or any(i not in world_columns for i in pair):
            return CAUSES[0], gap
        if any(first_seen[i] > last - LATE_FRAMES for i in pair):
            return CAUSES[1], gap
        if window == "future" and history_bodies & set(pair):
            return CAUSES[2], gap
        own = truth_events if kind == "miss" else world_events
        if any(p == pair and 0 < frame - f <= REPEAT_FRAMES for p, f in own):
            return CAUSES[3], gap
        if any(p == pair and abs(f - frame) <= TIMING_FRAMES for p, f in other):
            return CAUSES[4], gap
        if window == "future" and any(speed[i] <= STILL_MOVING_SPEED for i in pair):
            return CAUSES[5], gap
        if gap <= NEAR_MISS:
            return CAUSES[6], gap
        return CAUSES[7], gap

    rows = []
    for window, pick in (("video", in_video), ("future", after)):
        for kind, side, other in (("miss", truth_events, world_events), ("invented", world_events, truth_events)):
            for pair, frame in unmatched_events(pick(side), pick(other), EVENT_TOLERANCE_FRAMES):
                name, gap = cause(pair, frame, kind, window)
                rows.append({"scene": int(index), "window": window, "kind": kind, "pair": list(pair), "frame": int(frame),
                             "cause": name, "gap_m": gap})
        rows.append({"scene": int(index), "window": window, "kind": "counts",
                     "mujoco": len(pick(truth_events)), "world": len(pick(world_events))})
    return rows


def table(rows: list[dict]) -> list[str]:
    """Per window and cause: misses, inventions, and the median gap (cm) of the side without the event."""
    lines = []
    for window in ("future", "video"):
        counts = [r for r in rows if r.get("window") == window and r["kind"] == "counts"]
        lines.append(f"{window}: MuJoCo {sum(r['mujoco'] for r in counts)} collisions, world {sum(r['world'] for r in counts)}")
        lines.append(f"  {'cause':<16} {'missed':>6} {'invented':>8} | {'gap med (cm)':>12}")
        for name in CAUSES:
            group = [r for r in rows if r.get("window") == window and r.get("cause") == name]
            if not group:
                continue
            lines.append(f"  {name:<16} {sum(r['kind'] == 'miss' for r in group):>6} {sum(r['kind'] == 'invented' for r in group):>8} | "
                         f"{median_cm(group, 'gap_m', 12)}")
    return lines + failed_lines(rows)


def main(argv: list[str] | None = None) -> int:
    return miss_report_main(argv, __doc__.split("\n\n")[0], _scene_rows, table, workers=2)


if __name__ == "__main__":
    raise SystemExit(main())
