"""Why the world misses collisions of the video: each miss of the record and of the replay by cause.

For every MuJoCo collision in the observed window (frame <= last observed
frame) that the world's record (``World.observed_collisions``) or its fitted
replay does not hold (bench.metrics.match_events, 5-frame tolerance), the
first cause that applies:

1. ``out of view``: a body of the pair is not observed (weight 0) on any
   frame within +-2 of the contact;
2. ``video edge``: the contact is within segments.WINDOW frames of the first or
   last frame of the video, or of a body's first or last observed frame;
3. ``wrong pair``: the missing side has a collision of one of the two bodies
   with a third body within the tolerance;
4. ``simultaneous``: MuJoCo has another collision of one of the two bodies
   within segments.MIN_SEPARATION frames (several contacts in one impulse);
5. ``repeat``: MuJoCo has a collision of the same pair within 25 frames before
   (a push or a rattle, beyond the debounce);
6. ``body at rest``: one body's MuJoCo speed before the contact is below
   RESTING_SPEED;
7. ``glancing``: neither body's velocity changes by segments.MIN_DELTA_V
   (MuJoCo velocities, window of segments.WINDOW frames each side);
8. ``between frames``: at the frames around the contact the tracks'
   footprints (world.footprint, true sizes and yaws) stay apart by more than
   BETWEEN_FRAMES_GAP: the touch happened between two frames;
9. ``other``.

For the replay there is one more: ``not in record`` (the record misses it
too) is reported apart from ``in record`` (the fit had it and lost it).

    MUJOCO_GL=egl python -m bench.bench_observed_misses DATASET [--scenes N] [--workers 1]
        [--worlds DIR] [--save-worlds DIR] [--json rows.json]
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from bench.metrics import EVENT_TOLERANCE_FRAMES, GroundTruth, match_events, rollout_collisions, unmatched_events
from bench.runner import failed_lines, miss_report_main, scene_world
from world.footprint import footprint_gap
from world.identify.segments import MIN_DELTA_V, MIN_SEPARATION, WINDOW
from world.observations import Observations
from world.rollout import simulate

RESTING_SPEED = 0.02  # m/s
REPEAT_FRAMES = 25
BETWEEN_FRAMES_GAP = 0.01  # m
CAUSES = ("out of view", "video edge", "wrong pair", "simultaneous", "repeat", "body at rest", "glancing",
          "between frames", "other")


def _truth_speed_change(truth: GroundTruth, column: int, frame: int, fps: float) -> tuple[float, float]:
    """(speed before, |velocity change|) m/s of one MuJoCo body around ``frame`` (WINDOW frames each side)."""
    xy = truth.positions[:, column, :2]
    low, high = max(frame - WINDOW, 0), min(frame + WINDOW, xy.shape[0] - 1)
    before = (xy[frame] - xy[low]) / max(frame - low, 1) * fps
    after = (xy[high] - xy[frame]) / max(high - frame, 1) * fps
    return float(np.linalg.norm(before)), float(np.linalg.norm(after - before))


def _track_gap(observations: Observations, pair: tuple[int, int], frame: int) -> float:
    """Smallest footprint gap (m) of the pair's tracks at frames frame-1 .. frame+1 where both are observed."""
    tracks = {t.id: t for t in observations.objects}
    a, b = tracks[pair[0]], tracks[pair[1]]
    best = float("inf")
    for probe in (frame - 1, frame, frame + 1):
        ia, ib = np.flatnonzero(a.frames == probe), np.flatnonzero(b.frames == probe)
        if ia.size and ib.size and a.observed[ia[0]] and b.observed[ib[0]]:
            yaw_a, yaw_b = np.nan_to_num(a.yaw[ia]), np.nan_to_num(b.yaw[ib])
            gap = footprint_gap(a.shape, a.positions[ia], yaw_a, b.shape, b.positions[ib], yaw_b)
            best = min(best, float(gap[0]))
    return best


def _cause(pair, frame, truth: GroundTruth, observations: Observations, lacking: list, truth_events: list) -> str:
    tracks = {t.id: t for t in observations.objects}
    last = truth.observed_frames - 1
    for body in pair:
        track = tracks.get(body)
        near = np.abs(track.frames - frame) <= 2 if track is not None else np.zeros(0, bool)
        if track is None or not np.any(track.observed[near]):
            return CAUSES[0]
    seen = [tracks[b].frames[tracks[b].observed] for b in pair]
    if frame < WINDOW or frame > last - WINDOW or any(frame - s[0] < WINDOW or s[-1] - frame < WINDOW for s in seen):
        return CAUSES[1]
    if any(set(p) & set(pair) and p != pair and abs(f - frame) <= EVENT_TOLERANCE_FRAMES for p, f in lacking):
        return CAUSES[2]
    if any(set(p) & set(pair) and p != pair and abs(f - frame) < MIN_SEPARATION for p, f in truth_events):
        return CAUSES[3]
    if any(p == pair and 0 < frame - f <= REPEAT_FRAMES for p, f in truth_events):
        return CAUSES[4]
    columns = {body: k for k, body in enumerate(truth.object_ids)}
    changes = [_truth_speed_change(truth, columns[b], frame, observations.fps) for b in pair]
    if any(speed < RESTING_SPEED for speed, _ in changes):
        return CAUSES[5]
    if all(change < MIN_DELTA_V for _, change in changes):
        return CAUSES[6]
    if _track_gap(observations, pair, frame) > BETWEEN_FRAMES_GAP:
        return CAUSES[7]
    return CAUSES[8]


def _scene_rows(task: tuple[Path, Path | None, Path | None]) -> list[dict]:
    annotation, worlds, save_worlds = task
    index = annotation.stem.split("_")[-1]
    truth = GroundTruth.load(annotation.parent.parent / "ground_truth" / f"scene_{index}.json")
    observations = Observations.from_clevrer_annotation(annotation, camera=truth.camera)
    world = scene_world(annotation, observations, worlds, save_worlds)
    last = truth.observed_frames - 1
    truth_events = [e for e in truth.collisions if e[1] <= last]
    record = [((min(a, b), max(a, b)), f) for a, b, f in world.observed_collisions or () if f <= last]
    replay = rollout_collisions(simulate(world, (), truth.observed_frames), 0, last)
    rows = [{"scene": int(index), "kind": "counts", "mujoco": len(truth_events),
             "record": [match_events(record, truth_events).true_positives, len(record)],
             "replay": [match_events(replay, truth_events).true_positives, len(replay)]}]
    record_misses = unmatched_events(truth_events, record)
    for side, events in (("record", record), ("replay", replay)):
        for pair, frame in unmatched_events(truth_events, events):
            row = {"scene": int(index), "kind": "miss", "side": side, "pair": list(pair), "frame": int(frame),
                   "cause": _cause(pair, frame, truth, observations, events, truth_events),
                   "gap_m": _track_gap(observations, pair, frame)}
            if side == "replay":
                row["in_record"] = (pair, frame) not in record_misses
            rows.append(row)
        for pair, frame in unmatched_events(events, truth_events):
            rows.append({"scene": int(index), "kind": "invented", "side": side, "pair": list(pair), "frame": int(frame)})
    return rows


def table(rows: list[dict]) -> list[str]:
    """Totals, then per cause the misses of the record and of the replay (in record / not)."""
    counts = [r for r in rows if r["kind"] == "counts"]
    mujoco = sum(r["mujoco"] for r in counts)
    lines = [f"MuJoCo collisions in the video: {mujoco}"]
    for side in ("record", "replay"):
        hits, held = sum(r[side][0] for r in counts), sum(r[side][1] for r in counts)
        invented = sum(1 for r in rows if r["kind"] == "invented" and r["side"] == side)
        lines.append(f"  {side:<6}: {held} events, recall {hits / max(mujoco, 1):.3f}, precision "
                     f"{hits / max(held, 1):.3f}, {mujoco - hits} missed, {invented} invented")
    lines.append(f"  {'cause':<15} {'record':>6} | {'replay':>6} {'(in record':>10} {'not)':>5}")
    for name in CAUSES:
        record = sum(1 for r in rows if r["kind"] == "miss" and r["side"] == "record" and r["cause"] == name)
        replay = [r for r in rows if r["kind"] == "miss" and r["side"] == "replay" and r["cause"] == name]
        if record or replay:
            inside = sum(1 for r in replay if r["in_record"])
            lines.append(f"  {name:<15} {record:>6} | {len(replay):>6} {inside:>10} {len(replay) - inside:>5}")
    return lines + failed_lines(rows)


def main(argv: list[str] | None = None) -> int:
    return miss_report_main(argv, __doc__.split("\n\n")[0], _scene_rows, table, workers=1)


if __name__ == "__main__":
    raise SystemExit(main())
