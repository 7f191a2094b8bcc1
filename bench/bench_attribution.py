"""Where do answers from video get lost? Swap one perception output at a time for its oracle counterpart.

    MUJOCO_GL=egl physmind synth --out DATA --scenes 100 --seed 5151 --workers 2 [--looks heldout]
    nice -n 10 .venv/bin/python -m bench.bench_attribution DATA --workers 2 [--limit N] [--cache DIR] [--json OUT]

Per scene: perceive the video once (perception.pipeline.perceive), then build
one world per row with world.identify.fit.identify and answer every question
with the planner over the HTTP tools (as bench/bench_qa.py does):

* from video: the perceived Observations;
* oracle tracks: Observations.from_clevrer_annotation (bench_qa's row (b));
* swap identities: perceived samples (positions, attributes), but each
  frame's samples regrouped by the object they belong to (per-frame Hungarian
  on plane positions, gate GATE_M); samples of no object are dropped;
* swap attributes: perceived tracks with the colour, material and shape of
  the object matched to the track;
* swap material / swap shape: the same for one attribute only (its belief made
  certain, the other attributes' beliefs kept as perceived);
* swap positions (lifting): perceived tracks and frames with the true plane
  position and yaw of the object matched in that frame;
* swap entry/exit: each matched track starts and ends when its object is in
  view (perceived samples outside dropped; frames before the track's first
  and after its last usable sample filled with the true positions; gaps
  inside the track kept);
* swap collisions: identification's candidate collisions (change points,
  world.identify.segments) replaced by the true observed collisions.

Track-to-object matching: Hungarian over the whole video on the mean plane
distance between a track and an object over the frames both are seen
(MATCH_GATE_M at most); perceived tracks are relabelled with their object's
id (unmatched ones get 100 + their id) so worlds can be scored against the
truth; questions name objects by attributes, so ids do not change answers.

Identification report per row (bench.metrics.score_world against MuJoCo):
observed-window RMSE over visible frames, observed-window collision recall
of the fitted replay (5-frame tolerance), precision and recall of the world's
record of observed collisions (World.observed_collisions, which explanatory
answers use; same tolerance), and the share of the world's bodies matched to an object
whose material is the object's (after identification revised it by mass
ratios, world/identify/materials.py). The dataset must not overlap the fixtures (seed 12),
bench_qa (4242), bench_perception (777) or any tuning set.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from dataclasses import replace
from pathlib import Path
from unittest import mock

import numpy as np
from scipy.optimize import linear_sum_assignment

REPO = Path(__file__).resolve().parents[1]
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))

import multiprocessing
from concurrent.futures import ProcessPoolExecutor, as_completed

from tqdm import tqdm

from bench.bench_cached_answers import ungrounded_questions  # noqa: E402
from bench.metrics import GroundTruth, match_events, score_world  # noqa: E402
from perception.pipeline import perceive
from physmind.local_server import local_server
from planner.client import ToolClient
from planner.evaluate import evaluate, format_table, load_dataset
from planner.executor import ExecutorConfig
from world.identify import segments
from world.identify.fit import identify
from world.io import load_camera, world_to_dict
from world.observations import DEFAULT_OBJECT_SIZE, ObjectTrack, Observations, default_shape  # noqa: E402
from world.rollout import simulate

ROWS = ("from video", "oracle tracks", "swap identities", "swap attributes", "swap material", "swap shape", "swap positions",
        "swap entry/exit", "swap collisions")
SWAPS = ROWS[2:]
MATCH_GATE_M = 0.4  # m: a track farther than this (mean) from every object is no object's
GATE_M = 0.4  # m: per-frame sample-to-object gate (two object radii)
UNMATCHED_ID_OFFSET = 100


# -- truth -------------------------------------------------------------------------------


class Truth:
    """What the swaps need from ground_truth/scene_XXXXX.json (observed window only).

    positions (T, N, 3) m, yaw (T, N) rad, visible (T, N) bool, in ``ids`` order;
    attributes: id -> (color, material, shape); collisions: observed (a, b, frame).
    """

    def __init__(self, document: dict):
        from world.observations import _yaw_from_quaternion

        observed = int(document["observed_frames"])
        objects = document["trajectory"]["objects"]
        self.ids = tuple(int(o["object_id"]) for o in objects)
        self.positions = np.stack([np.asarray(o["location"][:observed], dtype=float) for o in objects], axis=1)
        self.yaw = np.array([[_yaw_from_quaternion(q) for q in o["orientation"][:observed]] for o in objects]).T
        self.visible = np.stack([np.asarray(o["inside_camera_view"][:observed], dtype=bool) for o in objects], axis=1)
        self.attributes = {int(o["object_id"]): (o["color"], o["material"], o["shape"]) for o in document["objects"]}
        self.collisions = tuple(
            (int(e["object_ids"][0]), int(e["object_ids"][1]), int(e["frame_id"])) for e in document["events"] if e["kind"] == "collision" and e["observed"]
        )
        self.observed_frames = observed


# -- matching ----------------------------------------------------------------------------


def match_tracks(observations: Observations, truth: Truth) -> dict[int, int]:
    """Track id -> object id: Hungarian on the mean plane distance over frames both are seen."""
    tracks = list(observations.objects)
    cost = np.full((len(tracks), len(truth.ids)), 1e6)
    for i, track in enumerate(tracks):
        frames = track.frames[track.observed]
        positions = track.positions[track.observed, :2]
        inside = frames < truth.observed_frames
        frames, positions = frames[inside], positions[inside]
        for k in range(len(truth.ids)):
            seen = truth.visible[frames, k]
            if seen.any():
                cost[i, k] = float(np.mean(np.linalg.norm(positions[seen] - truth.positions[frames[seen], k, :2], axis=1)))
    if cost.size == 0:
        return {}
    rows, cols = linear_sum_assignment(cost)
    return {tracks[r].id: truth.ids[c] for r, c in zip(rows, cols) if cost[r, c] <= MATCH_GATE_M}


def match_samples(observations: Observations, truth: Truth) -> dict[tuple[int, int], int]:
    """(track id, frame) -> object id: per-frame Hungarian on plane distance (gate GATE_M) among visible objects."""
    by_frame: dict[int, list[tuple[int, np.ndarray]]] = {}
    for track in observations.objects:
        for frame, position, used in zip(track.frames, track.positions, track.observed):
            if used and frame < truth.observed_frames:
                by_frame.setdefault(int(frame), []).append((track.id, position[:2]))
    matched = {}
    for frame, samples in by_frame.items():
        cost = np.linalg.norm(np.array([p for _, p in samples])[:, None, :] - truth.positions[frame, None, :, :2], axis=2)
        cost[:, ~truth.visible[frame]] = 1e6
        rows, cols = linear_sum_assignment(cost)
        for r, c in zip(rows, cols):
            if cost[r, c] <= GATE_M:
                matched[(samples[r][0], frame)] = truth.ids[c]
    return matched


def relabel(observations: Observations, assignment: dict[int, int]) -> Observations:
    """Tracks renamed to their object's id; unmatched ones to UNMATCHED_ID_OFFSET + id."""
    tracks = [replace(t, id=assignment.get(t.id, UNMATCHED_ID_OFFSET + t.id)) for t in observations.objects]
    return replace(observations, objects=tuple(tracks))


# -- the swaps (each returns perceived Observations with one output made oracle) -------


def _track(template: ObjectTrack, object_id: int, rows: list[tuple[int, np.ndarray, float, bool, float]]) -> ObjectTrack:
    rows = sorted(rows, key=lambda r: r[0])
    return ObjectTrack(
        id=object_id,
        shape=template.shape,
        frames=np.array([r[0] for r in rows], dtype=np.int64),
        positions=np.array([r[1] for r in rows], dtype=float).reshape(-1, 3),
        yaw=np.array([r[2] for r in rows], dtype=float),
        visible=np.array([r[3] for r in rows], dtype=bool),
        weights=np.array([r[4] for r in rows], dtype=float),
        color=template.color,
        material=template.material,
        attribute_belief=template.attribute_belief,
    )


def swap_identities(perceived: Observations, truth: Truth) -> Observations:
    """Every perceived sample goes to the object it belongs to in its frame; attributes from the
    track that gives the object most samples; samples of no object are dropped."""
    matched = match_samples(perceived, truth)
    rows: dict[int, list] = {}
    votes: dict[int, dict[int, int]] = {}
    tracks = {t.id: t for t in perceived.objects}
    for track in perceived.objects:
        for frame, position, yaw, visible, weight in zip(track.frames, track.positions, track.yaw, track.visible, track.weights):
            object_id = matched.get((track.id, int(frame)))
            if object_id is None:
                continue
            rows.setdefault(object_id, []).append((int(frame), position, float(yaw), bool(visible), float(weight)))
            votes.setdefault(object_id, {}).setdefault(track.id, 0)
            votes[object_id][track.id] += 1
    objects = []
    for object_id, samples in sorted(rows.items()):
        donor = tracks[max(votes[object_id], key=votes[object_id].get)]
        # One sample per frame: two tracks on one object in one frame cannot both be matched (Hungarian).
        objects.append(_track(donor, object_id, samples))
    return replace(perceived, objects=tuple(objects))


def swap_attributes(perceived: Observations, truth: Truth, assignment: dict[int, int],
                    names: tuple[str, ...] = ("color", "material", "shape")) -> Observations:
    """Each matched track takes its object's true value of each attribute in names; a
    swapped attribute's belief becomes certain, the others' stay as perceived."""
    tracks = []
    for track in perceived.objects:
        object_id = assignment.get(track.id)
        if object_id is None:
            tracks.append(track)
            continue
        true_values = dict(zip(("color", "material", "shape"), truth.attributes[object_id]))
        changes = {name: true_values[name] for name in names}
        if "shape" in changes:
            changes["shape"] = default_shape(changes["shape"], DEFAULT_OBJECT_SIZE)
        belief = track.attribute_belief
        if belief is not None and set(names) != {"color", "material", "shape"}:
            certain = {name: ((true_values[name], 1.0),) for name in names}
            belief = replace(belief, **certain)
        else:
            belief = None  # all true: no perceived belief goes with them
        tracks.append(replace(track, attribute_belief=belief, **changes))
    return replace(perceived, objects=tuple(tracks))


def swap_positions(perceived: Observations, truth: Truth) -> Observations:
    matched = match_samples(perceived, truth)
    column = {object_id: k for k, object_id in enumerate(truth.ids)}
    tracks = []
    for track in perceived.objects:
        positions, yaw = track.positions.copy(), track.yaw.copy()
        for i, frame in enumerate(track.frames):
            object_id = matched.get((track.id, int(frame)))
            if object_id is not None:
                positions[i] = truth.positions[frame, column[object_id]]
                yaw[i] = truth.yaw[frame, column[object_id]]
        tracks.append(replace(track, positions=positions, yaw=yaw))
    return replace(perceived, objects=tuple(tracks))


def swap_entry_exit(perceived: Observations, truth: Truth, assignment: dict[int, int]) -> Observations:
    """Each matched track starts at its object's first in-view frame and ends at its last:
    perceived samples outside the object's in-view frames are dropped, the frames
    before the track's first usable sample and after its last are filled with
    the true positions; gaps inside the track stay as perceived."""
    column = {object_id: k for k, object_id in enumerate(truth.ids)}
    tracks = []
    for track in perceived.objects:
        object_id = assignment.get(track.id)
        if object_id is None or not track.observed.any():
            tracks.append(track)
            continue
        k = column[object_id]
        in_view = np.flatnonzero(truth.visible[:, k])
        usable = track.frames[track.observed]
        first, last = int(usable[0]), int(usable[-1])
        own = {int(f): i for i, f in enumerate(track.frames)}
        rows = []
        for frame in in_view:
            i = own.get(int(frame))
            if first <= frame <= last:
                if i is not None:
                    rows.append((int(frame), track.positions[i], float(track.yaw[i]), bool(track.visible[i]), float(track.weights[i])))
            else:
                rows.append((int(frame), truth.positions[frame, k], float(truth.yaw[frame, k]), True, 1.0))
        if rows:
            tracks.append(_track(track, track.id, rows))
    return replace(perceived, objects=tuple(tracks))


def true_candidates(observations: Observations, truth: Truth, gravity: float = 9.81, friction_prior: float = 0.3) -> list:
    """The true observed collisions as identification candidates (same velocity windows as
    world.identify.segments.find_candidate_collisions, bounded by the body's other true collisions)."""
    tracks = {t.id: t for t in observations.objects}
    fps = observations.fps
    frames_of: dict[int, list[int]] = {}
    for a, b, frame in truth.collisions:
        for body in (a, b):
            frames_of.setdefault(body, []).append(frame)
    candidates = []
    for a, b, frame in sorted(truth.collisions, key=lambda c: (c[2], c[0], c[1])):
        if a not in tracks or b not in tracks:
            continue
        pre, post = [], []
        for body in (a, b):
            others = [f for f in frames_of[body] if f != frame]
            low = max([f for f in others if f < frame] + [frame - 2 * segments.WINDOW])
            high = min([f for f in others if f > frame] + [frame + 2 * segments.WINDOW])
            pre.append(segments._side_velocity(tracks[body], np.arange(low + 1, frame), frame / fps, fps, gravity, friction_prior))
            post.append(segments._side_velocity(tracks[body], np.arange(frame + 1, high), frame / fps, fps, gravity, friction_prior))
        here = [tracks[body].positions[np.argmin(np.abs(tracks[body].frames - frame)), :2] for body in (a, b)]
        offset = here[1] - here[0]
        normal = offset / max(float(np.hypot(*offset)), 1e-9)
        candidates.append(segments.CandidateCollision((a, b), frame, np.array(pre), np.array(post), normal))
    return candidates


# -- one scene -------------------------------------------------------------------------------


def _fit(observations: Observations, truth_path: Path, truth: Truth, candidates: list | None = None) -> dict:
    """identify -> world document + the identification report against MuJoCo."""
    started = time.perf_counter()
    if candidates is None:
        world, report = identify(observations)
    else:
        # The oracle counterpart of the change-point detector: identify's own call replaced (bench only).
        with mock.patch("world.identify.fit.find_candidate_collisions", lambda *args, **kwargs: list(candidates)):
            world, report = identify(observations)
    seconds = time.perf_counter() - started
    ground = GroundTruth.load(truth_path)
    order = {object_id: k for k, object_id in enumerate(truth.ids)}
    visible = np.stack([truth.visible[:, order[i]] for i in ground.object_ids], axis=1)
    score = score_world(world, ground, lambda w, e, h: simulate(w, e, horizon_frames=h), visible=visible)
    return {
        "world": world_to_dict(world),
        "fit_seconds": seconds,
        "rmse": score.rmse,
        "observed": score.observed.counts(),
        # The world's record of observed collisions (World.observed_collisions) against MuJoCo's.
        "record": match_events([((a, b), frame) for a, b, frame in world.observed_collisions or ()],
                               [((a, b), frame) for a, b, frame in truth.collisions]).counts(),
        "bodies": len(world.bodies),
        # The world's material of each body that is an object (relabelled id): right, judged.
        "materials": (sum(b.material == truth.attributes[b.id][1] for b in world.bodies if b.id in truth.attributes),
                       sum(b.id in truth.attributes for b in world.bodies)),
    }


def attribute_scene(job: tuple) -> dict:
    """The rows of one scene (job: (dataset, scene index[, rows to fit; default all])); a failure is recorded per row, never raised."""
    root, index = Path(job[0]), job[1]
    wanted = set(job[2]) if len(job) > 2 else set(ROWS)

    name = f"{index:05d}"
    truth_path = root / "ground_truth" / f"scene_{name}.json"
    truth = Truth(json.loads(truth_path.read_text()))
    camera = load_camera(truth_path)
    result: dict = {"scene": index, "rows": {}}
    started = time.perf_counter()
    try:
        perceived_raw = perceive(root / "videos" / f"video_{name}.mp4", camera)
    except Exception as error:  # noqa: BLE001 - the table reports failures
        result["perceive_error"] = f"{type(error).__name__}: {error}"
        perceived_raw = None
    result["perceive_seconds"] = time.perf_counter() - started
    oracle = Observations.from_clevrer_annotation(root / "annotations" / f"annotation_{name}.json", camera=camera)
    variants: dict[str, tuple[Observations, list | None]] = {"oracle tracks": (oracle, None)}
    if perceived_raw is not None:
        assignment = match_tracks(perceived_raw, truth)
        perceived = relabel(perceived_raw, assignment)
        ids = {t.id: t.id for t in perceived.objects if t.id < UNMATCHED_ID_OFFSET}  # relabelled: id is the object's
        result["tracks"] = len(perceived.objects)
        result["matched"] = len(ids)
        result["objects"] = len(truth.ids)
        variants["from video"] = (perceived, None)
        variants["swap identities"] = (swap_identities(perceived, truth), None)
        variants["swap attributes"] = (swap_attributes(perceived, truth, ids), None)
        variants["swap material"] = (swap_attributes(perceived, truth, ids, ("material",)), None)
        variants["swap shape"] = (swap_attributes(perceived, truth, ids, ("shape",)), None)
        variants["swap positions"] = (swap_positions(perceived, truth), None)
        variants["swap entry/exit"] = (swap_entry_exit(perceived, truth, ids), None)
        variants["swap collisions"] = (perceived, true_candidates(perceived, truth))
    for row, (observations, candidates) in variants.items():
        if row not in wanted:
            continue
        try:
            result["rows"][row] = _fit(observations, truth_path, truth, candidates)
        except Exception as error:  # noqa: BLE001
            result["rows"][row] = {"error": f"{type(error).__name__}: {error}"}
    return result


def missing_rows(cached: dict, rows: list[str]) -> tuple[str, ...]:
    """The rows a cached scene result lacks (a cache written by a run with other --rows); none when its video
    could not be perceived (every row but the oracle's needs it, and trying again gives the same failure)."""
    return tuple(r for r in rows if r not in cached["rows"] and (r == "oracle tracks" or "perceive_error" not in cached))


def merge_rows(cached: dict | None, fresh: dict) -> dict:
    """A scene's cached result with the rows of a fresh run added (the fresh run's rows and perception win)."""
    if cached is None:
        return fresh
    return cached | {k: v for k, v in fresh.items() if k != "rows"} | {"rows": cached["rows"] | fresh["rows"]}


# -- tables ----------------------------------------------------------------------------------


def identification_table(results: list[dict]) -> str:
    lines = ["| row | worlds | observed-window RMSE median (m) | p90 (m) | observed collision recall | record of observed collisions P / R "
             "| world material right | fit s median |",
             "|---|---|---|---|---|---|---|---|"]
    for row in ROWS:
        if not any(row in r["rows"] for r in results):
            continue
        fits = [r["rows"][row] for r in results if row in r["rows"] and "error" not in r["rows"][row]]
        if not fits:
            continue
        rmse = [f["rmse"] for f in fits if np.isfinite(f["rmse"])]
        hits, actual = sum(f["observed"][0] for f in fits), sum(f["observed"][2] for f in fits)
        right, judged = (sum(f.get("materials", (0, 0))[k] for f in fits) for k in (0, 1))
        records = [f["record"] for f in fits if "record" in f]  # caches written before the column have none
        kept, recorded, true = (sum(r[k] for r in records) for k in range(3))
        record = f"{kept / max(recorded, 1):.3f} / {kept / max(true, 1):.3f} ({kept}/{recorded}, {kept}/{true})" if records else "-"
        lines.append(
            f"| {row} | {len(fits)} | {np.median(rmse):.4f} | {np.percentile(rmse, 90):.4f} | {hits / max(actual, 1):.3f} ({hits}/{actual}) | "
            f"{record} | {right / max(judged, 1):.3f} ({right}/{judged}) | "
            f"{statistics.median(f['fit_seconds'] for f in fits):.2f} |"
        )
    return "\n".join(lines)


def gains_table(tables: dict) -> str:
    """Points each swap wins back over the from-video row, per question (and per option)."""
    base = tables.get("from video")
    if base is None:
        return ""
    lines = ["| swap | " + " | ".join(f"{k} per ques. / per opt." for k in ("explanatory", "predictive", "counterfactual", "overall")) + " |", "|---|---|---|---|---|"]
    for row in SWAPS:
        if row not in tables:
            continue
        cells = []
        for kind in ("explanatory", "predictive", "counterfactual", "overall"):
            a, b = tables[row][kind], base[kind]
            if a.per_question is None or b.per_question is None:
                cells.append("-")
            else:
                cells.append(f"{a.per_question - b.per_question:+.1f} / {a.per_option - b.per_option:+.1f}")
        lines.append(f"| {row} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("data", type=Path, help="dataset written by physmind synth")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--limit", type=int, default=None, help="only the first N scenes")
    parser.add_argument("--cache", type=Path, default=None, help="keep per-scene results (scene_XXXXX.json) here and reuse them")
    parser.add_argument("--cached-only", action="store_true", help="report on the scenes already in --cache only (no new perception)")
    parser.add_argument("--json", type=Path, default=None, help="write the tables, per-scene reports and every question's record per row here")
    parser.add_argument("--rows", default=",".join(ROWS), help=f"comma-separated rows to fit and score (default all: {', '.join(ROWS)})")
    args = parser.parse_args(argv)
    rows = [r.strip() for r in args.rows.split(",") if r.strip()]
    unknown = [r for r in rows if r not in ROWS]
    if unknown:
        raise SystemExit(f"--rows: unknown row(s) {unknown}; expected among {list(ROWS)}")


    entries = load_dataset(args.data, limit=args.limit)
    if args.cached_only:
        if args.cache is None:
            raise SystemExit("--cached-only: needs --cache DIR")
        entries = [e for e in entries if (args.cache / f"scene_{e.scene_index:05d}.json").is_file()]
    print(f"# {len(entries)} scenes, {sum(len(e.questions) for e in entries)} questions from {args.data}")
    results: dict[int, dict] = {}
    todo = []
    for entry in entries:
        cached = None if args.cache is None else args.cache / f"scene_{entry.scene_index:05d}.json"
        result = json.loads(cached.read_text()) if cached is not None and cached.is_file() else None
        missing = tuple(rows) if result is None else missing_rows(result, rows)
        if result is not None:
            results[entry.scene_index] = result
        if missing and args.cached_only:
            print(f"warning: scene {entry.scene_index}: rows {list(missing)} are not in the cache and count as unanswered (--cached-only)")
        elif missing:
            todo.append((str(args.data), entry.scene_index, missing))

    def keep(result: dict) -> None:
        result = merge_rows(results.get(result["scene"]), result)
        results[result["scene"]] = result
        if args.cache is not None:
            args.cache.mkdir(parents=True, exist_ok=True)
            (args.cache / f"scene_{result['scene']:05d}.json").write_text(json.dumps(result))

    with tqdm(total=len(todo), desc="perceive + fit rows", unit="video") as bar:
        if args.workers <= 1:
            for job in todo:
                keep(attribute_scene(job))
                bar.update()
        else:
            with ProcessPoolExecutor(args.workers, mp_context=multiprocessing.get_context("spawn")) as pool:
                for future in as_completed([pool.submit(attribute_scene, job) for job in todo]):
                    keep(future.result())
                    bar.update()

    ordered = [results[e.scene_index] for e in entries]
    tables, ungrounded, answers = {}, {}, {}
    with local_server() as url, ToolClient(url) as client:
        for row in rows:
            worlds = {r["scene"]: r["rows"][row]["world"] for r in ordered if row in r["rows"] and "world" in r["rows"][row]}
            infos = {r["scene"]: {"error": r["rows"].get(row, {}).get("error") or r.get("perceive_error", "no world")} for r in ordered if r["scene"] not in worlds}
            evaluated = evaluate(entries, worlds, client, ExecutorConfig(mode="execute"), progress=False, build_info=infos)
            tables[row] = evaluated.table()
            ungrounded[row] = ungrounded_questions(evaluated.records)
            answers[row] = [record.to_dict() for record in evaluated.records]
    print("\n## accuracy (%), per question / per option")
    print(format_table(tables))
    print("\n## questions with a reference not grounded (question or an option), per row")
    for row, count in ungrounded.items():
        print(f"{row}: {count} of {sum(len(e.questions) for e in entries)}")
    print("\n## points won back over from-video by each swap (per question / per option)")
    print(gains_table(tables))
    print("\n## identification report per row (against MuJoCo, observed window)")
    print(identification_table(ordered))
    perceive_s = [r["perceive_seconds"] for r in ordered]
    failed = [r["scene"] for r in ordered if "perceive_error" in r]
    print(f"\nperceive: median {statistics.median(perceive_s):.1f} s, max {max(perceive_s):.1f} s per video; failed: {failed}")
    tracks = sum(r.get("tracks", 0) for r in ordered)
    matched = sum(r.get("matched", 0) for r in ordered)
    objects = sum(r.get("objects", 0) for r in ordered)
    print(f"perceived tracks {tracks}, matched to an object {matched}, objects {objects} (in scenes perceived)")
    if args.json:
        args.json.write_text(json.dumps({"tables": {k: {c: t.to_dict() for c, t in v.items()} for k, v in tables.items()}, "answers": answers,
                                         "scenes": [{k: v for k, v in r.items() if k != "rows"} | {"rows": {n: {k: v for k, v in f.items() if k != "world"} for n, f in r["rows"].items()}} for r in ordered]}, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
