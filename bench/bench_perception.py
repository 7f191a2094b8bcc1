"""Benchmark of perception (video -> tracked objects) against the generator's truth.

Usage:
  MUJOCO_GL=egl physmind synth --out /tmp/perc_bench --scenes 50 --seed 777 --workers 2
  python -m bench.bench_perception /tmp/perc_bench [--limit N] [--no-e2e] [--no-build] [--worst K] [--json OUT]
  python -m bench.bench_perception --from-json OUT1 OUT2   # the tables of saved per-scene results together

Per video: perceive, then match perceived tracks to the generator's objects by
total mask IoU over frames (Hungarian). Masks of perceived objects are the
fitted primitives' visible silhouettes (pipeline.instance_map).

* detection recall / precision per frame at mask IoU >= 0.5, on frames where
  the object is fully in view (its true mask does not touch the image border;
  perceived masks likewise), objects with >= 50 visible pixels;
* identity switches: changes of the perceived id covering one true object
  between consecutive covered frames; fragmented: true objects covered by
  more than one perceived id;
* position error on the plane (xy, in object radii = 0.2 m) of matched tracks
  over frames with the object fully in view and weight > 0;
* colour / shape / material accuracy of matched tracks, and the wrong shapes by kind (true -> read);
* segments the tracker split between tracks, by the true object centres they hold: one object's segment split
  gives each track a piece to lift as if it were a whole object;
* wall time and CPU time per video (decode + perceive), per stage; and the CPU time of `physmind build`
  (decode + perceive + fit: world.identify.fit.identify and the world document), unless --no-build;
* end to end: perceived vs oracle observations -> world.identify.fit.identify
  -> bench.metrics.score_world: predictive and counterfactual collision F1.
"""

from __future__ import annotations

import argparse
import json
import os
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
from scipy.optimize import linear_sum_assignment
from tqdm import tqdm

from bench.metrics import GroundTruth, score_world
from perception.pipeline import instance_map, perceive_frames
from perception.video import read_video
from synth.masks import decode_mask
from world.camera import project
from world.identify.fit import identify
from world.io import load_camera, world_to_dict
from world.observations import Observations
from world.rollout import simulate
from world.types import Camera

RADIUS = 0.2  # m, object radius (the unit of position errors)
MIN_AREA = 50


def _masks(path: Path) -> tuple[dict, list[dict[int, np.ndarray]]]:
    document = json.loads(path.read_text())
    per_frame = [{o["object_id"]: decode_mask(o["mask"]) for o in fr["objects"]} for fr in document["frames"]]
    attributes = {}
    for fr in document["frames"]:
        for o in fr["objects"]:
            attributes[o["object_id"]] = (o["color"], o["shape"], o["material"])
    return attributes, per_frame


def _touches_border(mask: np.ndarray) -> bool:
    return bool(mask[0].any() or mask[-1].any() or mask[:, 0].any() or mask[:, -1].any())


def evaluate_scene(root: Path, index: int, e2e: bool, build: bool = True) -> dict:
    name = f"{index:05d}"
    camera = load_camera(root / "ground_truth" / f"scene_{name}.json")
    began, began_cpu = time.perf_counter(), time.process_time()
    frames, fps = read_video(root / "videos" / f"video_{name}.mp4")
    try:
        observations, inter = perceive_frames(frames, camera, fps=fps)
        refused = None
    except ValueError as error:  # perception refused the video: every object counts as missed, the table says so
        observations, inter, refused = None, {"lifted": [], "timings": {}}, str(error)
    wall, cpu = time.perf_counter() - began, time.process_time() - began_cpu
    fit_cpu = None
    if build and observations is not None:  # what `physmind build` adds to perceive (physmind.pipeline.build_world): the fit and the world document
        fit_began = time.process_time()
        world_to_dict(identify(observations)[0])
        fit_cpu = time.process_time() - fit_began
    lifted = inter["lifted"]
    attributes, true_masks = _masks(root / "masks" / f"proposal_{name}.json")
    annotation = json.loads((root / "annotations" / f"annotation_{name}.json").read_text())
    true_ids = sorted(attributes)
    pred_ids = [t.id for t in lifted]
    num_frames = len(true_masks)
    pred_maps = [instance_map(camera, lifted, f) for f in range(num_frames)]

    # Per-frame IoU tables and the global track <-> object assignment.
    overlap = np.zeros((len(pred_ids), len(true_ids)))
    ious = []
    for f in range(num_frames):
        table = {}
        for pi, p in enumerate(pred_ids):
            pm = pred_maps[f] == p
            if not pm.any():
                continue
            for ti, t in enumerate(true_ids):
                tm = true_masks[f].get(t)
                if tm is None:
                    continue
                inter_px = np.logical_and(pm, tm).sum()
                if inter_px:
                    iou = inter_px / np.logical_or(pm, tm).sum()
                    table[(pi, ti)] = iou
                    overlap[pi, ti] += iou
        ious.append(table)
    rows, cols = linear_sum_assignment(-overlap) if overlap.size else ([], [])
    assigned = {int(r): int(c) for r, c in zip(rows, cols) if overlap[r, c] > 0}

    tp_recall = n_true = tp_precision = n_pred = 0
    switches = 0
    covering: dict[int, list[int]] = {t: [] for t in range(len(true_ids))}
    for f in range(num_frames):
        for ti, t in enumerate(true_ids):
            tm = true_masks[f].get(t)
            if tm is None or tm.sum() < MIN_AREA or _touches_border(tm):
                continue
            n_true += 1
            best = max(((iou, pi) for (pi, tj), iou in ious[f].items() if tj == ti), default=(0.0, -1))
            if best[0] >= 0.5:
                tp_recall += 1
                covering[ti].append(best[1])
        for pi, p in enumerate(pred_ids):
            pm = pred_maps[f] == p
            if pm.sum() < MIN_AREA or _touches_border(pm):
                continue
            n_pred += 1
            if max((iou for (pj, _), iou in ious[f].items() if pj == pi), default=0.0) >= 0.5:
                tp_precision += 1
    fragmented = 0
    for ti, seq in covering.items():
        switches += sum(1 for a, b in zip(seq, seq[1:]) if a != b)
        fragmented += len(set(seq)) > 1

    # Positions and attributes of matched tracks.
    locations = {o["object_id"]: {} for o in annotation["object_property"]}
    for entry in annotation["motion_trajectory"]:
        for o in entry["objects"]:
            locations[o["object_id"]][entry["frame_id"]] = np.asarray(o["location"])
    errors = []
    attribute_hits = {"color": [], "shape": [], "material": []}
    for pi, ti in assigned.items():
        track, true_id = lifted[pi], true_ids[ti]
        for frame, position, weight in zip(track.frames, track.positions, track.weights):
            tm = true_masks[frame].get(true_id)
            if weight <= 0 or tm is None or _touches_border(tm):
                continue
            errors.append(np.linalg.norm(position[:2] - locations[true_id][int(frame)][:2]) / RADIUS)
        color, shape, material = attributes[true_id]
        attribute_hits["color"].append(track.attributes.color == color)
        attribute_hits["shape"].append(track.attributes.shape == shape)
        attribute_hits["material"].append(track.attributes.material == material)
        attribute_hits.setdefault("features", []).append((shape, material, track.attributes.shape, track.attributes.metal_probability, track.attributes.shape_score))
    missed_objects = len(true_ids) - len(assigned)

    # Entry / exit frames (CLEVRER "in" / "out": first frame in view after frame 0, first frame out of view).
    in_view = {o["object_id"]: np.zeros(num_frames, bool) for o in annotation["object_property"]}
    for entry in annotation["motion_trajectory"]:
        for o in entry["objects"]:
            if entry["frame_id"] < num_frames:
                in_view[o["object_id"]][entry["frame_id"]] = bool(o.get("inside_camera_view", True))
    event_errors, event_signed = [], {"in": [], "out": []}
    for pi, ti in assigned.items():
        track, seen = lifted[pi], in_view[true_ids[ti]]
        perceived = np.zeros(num_frames, bool)
        perceived[track.frames[track.visible]] = True
        for kind, truth_frame, our_frame in (("in", _first(seen), _first(perceived)), ("out", _last(seen) + 1, _last(perceived) + 1)):
            if kind == "in" and 0 < truth_frame < num_frames or kind == "out" and 0 < truth_frame < num_frames:
                event_errors.append(abs(truth_frame - our_frame))
                event_signed[kind].append(our_frame - truth_frame)

    split = split_segments(inter.get("tracks", []), camera, locations)
    result = {
        "scene": index, "wall_s": wall, "cpu_s": cpu, "fit_cpu_s": fit_cpu, "recall": (tp_recall, n_true), "precision": (tp_precision, n_pred),
        "split_segments": split,
        "switches": switches, "fragmented": fragmented, "errors": errors, "attributes": attribute_hits,
        "objects": len(true_ids), "tracks": len(pred_ids), "missed_objects": missed_objects,
        "timings": inter["timings"], "event_errors": event_errors, "event_signed": event_signed,
        "condition": _condition(json.loads((root / "ground_truth" / f"scene_{name}.json").read_text())),
        "refused": refused,
    }
    if e2e and observations is not None:
        relabelled = []
        for track in observations.objects:
            pi = pred_ids.index(track.id)
            new_id = true_ids[assigned[pi]] if pi in assigned else 100 + track.id
            relabelled.append(replace(track, id=new_id))
        perceived = replace(observations, objects=tuple(relabelled))
        oracle = Observations.from_clevrer_annotation(root / "annotations" / f"annotation_{name}.json", camera=camera)
        result["e2e"] = {"perceived": _score(perceived, root, name), "oracle": _score(oracle, root, name)}
    return result


def split_segments(tracks: list, camera: Camera, centres: dict[int, dict[int, np.ndarray]]) -> tuple[int, int]:
    """(segments holding at most one true object's centre, segments holding two or more) among the segments the
    tracker split between tracks (perception.track: k-means among same-coloured claimants; the pieces of one
    segment share frame, component and colour label). tracks: perception.types.TrackState; centres: object id ->
    frame -> (3,) true centre, m. A centre counts when its pixel is one of the segment's."""
    pieces: dict[tuple[int, int, int], list] = {}
    for track in tracks:
        for frame, detection in track.detections.items():
            if detection.split:
                pieces.setdefault((frame, detection.component, detection.hue_label), []).append(detection)
    one = more = 0
    for (frame, _, _), parts in pieces.items():
        here = [per_frame[frame] for per_frame in centres.values() if frame in per_frame]
        pixels = np.rint(project(camera, np.asarray(here, dtype=float).reshape(-1, 3)))  # (M, 2) u, v; NaN behind
        held = sum(any(np.any((part.xs == u) & (part.ys == v)) for part in parts) for u, v in pixels)
        if held >= 2:
            more += 1
        else:
            one += 1
    return one, more


def shape_confusions(features: list[tuple]) -> str:
    """The wrong shape decisions of matched tracks, most frequent first: "cylinder -> cube 3, ..." ("none" when all
    are right). features: (true shape, true material, decided shape, P(metal), shape score) per matched track."""
    counts: dict[tuple[str, str], int] = {}
    for true_shape, _, decided, *_ in features:
        if decided != true_shape:
            counts[(true_shape, decided)] = counts.get((true_shape, decided), 0) + 1
    ranked = sorted(counts.items(), key=lambda item: (-item[1], item[0]))
    return ", ".join(f"{a} -> {b} {n}" for (a, b), n in ranked) or "none"


def _condition(ground_truth: dict) -> str:
    """The appearance condition a video was rendered in, for the per-condition table.

    MuJoCo renders are named by their look's floor texture and shadows; POV-Ray and Blender renders by the renderer
    and the floor kind of its own look (their MuJoCo look, also in the file, is not what the video shows).
    """
    renderer = ground_truth.get("renderer") or {}
    if renderer.get("name") not in (None, "mujoco"):
        return f"{renderer['name']}: {((renderer.get('look') or {}).get('floor') or {}).get('kind', 'default')} floor"
    look = ground_truth.get("look") or {}
    return f"{(look.get('floor') or {}).get('texture', 'default')} floor, {(look.get('light') or {}).get('shadows', 'default')} shadows"


def _first(flags: np.ndarray) -> int:
    hits = np.flatnonzero(flags)
    return int(hits[0]) if hits.size else len(flags)


def _last(flags: np.ndarray) -> int:
    hits = np.flatnonzero(flags)
    return int(hits[-1]) if hits.size else -1


def _score(observations, root: Path, name: str) -> dict:
    truth = GroundTruth.load(root / "ground_truth" / f"scene_{name}.json")
    world, _ = identify(observations)
    score = score_world(world, truth, lambda w, e, h: simulate(w, e, horizon_frames=h))
    cf = score.counterfactual
    return {
        "predictive": (score.predictive.true_positives, score.predictive.predicted, score.predictive.actual),
        "counterfactual": (sum(c.true_positives for c in cf), sum(c.predicted for c in cf), sum(c.actual for c in cf)),
        "rmse": score.rmse,
    }


def _f1(tp: int, predicted: int, actual: int) -> float:
    p = tp / predicted if predicted else 1.0
    r = tp / actual if actual else 1.0
    return 2 * p * r / (p + r) if p + r else 0.0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("root", type=Path, nargs="?", help="dataset written by `physmind synth`")
    parser.add_argument("--from-json", type=Path, nargs="+", metavar="JSON",
                        help="print the tables from per-scene results saved with --json (e.g. halves of a dataset run in parallel) instead of running")
    parser.add_argument("--limit", type=int, default=None)
    parser.add_argument("--no-e2e", action="store_true", help="skip identification end to end")
    parser.add_argument("--no-build", action="store_true", help="skip the build timing (identification of the perceived tracks)")
    parser.add_argument("--worst", type=int, default=5, help="list this many weakest scenes")
    parser.add_argument("--json", type=Path, help="also write per-scene results here")
    args = parser.parse_args(argv)

    if args.from_json:
        results = [r for path in args.from_json for r in json.loads(path.read_text())]
        args.root = ", ".join(str(path) for path in args.from_json)
        args.no_e2e = not all("e2e" in r for r in results if not r.get("refused"))
    elif args.root is None:
        parser.error("give a dataset directory or --from-json")
    else:
        indices = sorted(int(p.stem.split("_")[1]) for p in (args.root / "videos").glob("video_*.mp4"))[: args.limit]
        results = [evaluate_scene(args.root, i, not args.no_e2e, not args.no_build) for i in tqdm(indices, desc="bench", unit="video")]

    def total(key: str) -> tuple[int, int]:
        return sum(r[key][0] for r in results), sum(r[key][1] for r in results)

    recall, precision = total("recall"), total("precision")
    errors = np.concatenate([np.asarray(r["errors"], dtype=float) for r in results if r["errors"]] or [np.zeros(0)])
    walls = np.array([r["wall_s"] for r in results])
    print(f"\nperception on {len(results)} videos of {args.root}")
    print("| metric | value | target |\n|---|---|---|")
    print(f"| detection recall (IoU>=0.5, fully in view) | {recall[0] / max(recall[1], 1):.4f} ({recall[0]}/{recall[1]}) | >= 0.97 |")
    print(f"| detection precision | {precision[0] / max(precision[1], 1):.4f} ({precision[0]}/{precision[1]}) | >= 0.97 |")
    print(f"| identity switches | {sum(r['switches'] for r in results)} in {len(results)} videos | <= 1 per 20 videos |")
    print(f"| fragmented objects | {sum(r['fragmented'] for r in results)} of {sum(r['objects'] for r in results)} | |")
    print(f"| objects without a track | {sum(r['missed_objects'] for r in results)} | |")
    refused = [r for r in results if r.get("refused")]
    reasons = "".join(f"; scene {r['scene']}: {r['refused']}" for r in refused)
    print(f"| videos perception refused (error) | {len(refused)}{reasons} | 0 |")
    print(f"| spurious tracks | {sum(max(r['tracks'] - (r['objects'] - r['missed_objects']), 0) for r in results)} | |")
    split = [r["split_segments"] for r in results if "split_segments" in r]  # results saved before the column have none
    if split:
        print(f"| segments split between tracks, holding one true object / two or more | {sum(s[0] for s in split)} / "
              f"{sum(s[1] for s in split)} | 0 / - |")
    if errors.size:
        print(f"| position error median (radii) | {np.median(errors):.3f} | <= 0.1 |")
        print(f"| position error p95 (radii) | {np.percentile(errors, 95):.3f} | |")
    for key, target in (("color", 0.98), ("shape", 0.95), ("material", 0.90)):
        hits = [h for r in results for h in r["attributes"][key]]
        print(f"| {key} accuracy | {sum(hits) / max(len(hits), 1):.4f} ({sum(hits)}/{len(hits)}) | >= {target} |")
    features = [f for r in results for f in r["attributes"].get("features", [])]
    if features:  # (true shape, true material, decided shape, P(metal), shape score) per matched track
        truth_metal = np.array([f[1] == "metal" for f in features])
        p_metal = np.clip(np.array([f[3] for f in features], dtype=float), 1e-6, 1 - 1e-6)
        print(f"| material log loss of P(metal) (matched tracks) | {float(np.mean(-np.log(np.where(truth_metal, p_metal, 1 - p_metal)))):.3f} | |")
        print(f"| shapes read wrong, true -> read (count) | {shape_confusions(features)} | none |")
    events = np.concatenate([r["event_errors"] for r in results if r["event_errors"]] or [np.zeros(0)])
    if events.size:
        print(f"| entry/exit frame error: within 2 frames / median / max | {np.mean(events <= 2):.3f} ({int(np.sum(events <= 2))}/{events.size}) "
              f"/ {np.median(events):.0f} / {events.max():.0f} | all within 2 |")
        for kind in ("in", "out"):
            signed = [e for r in results for e in r["event_signed"][kind]]
            if signed:
                print(f"| {kind} frame, perceived - true: median / min / max (count) | {np.median(signed):+.0f} / {min(signed):+d} / {max(signed):+d} ({len(signed)}) | 0 |")
    if errors.size:
        print(f"| position error median / p95 (cm) | {np.median(errors) * RADIUS * 100:.2f} / {np.percentile(errors, 95) * RADIUS * 100:.2f} | median <= 1 |")
    print(f"| wall time per video (s) median / max (decode + perceive) | {np.median(walls):.2f} / {walls.max():.2f} | <= 3 / <= 8 |")
    cpus = np.array([r["cpu_s"] for r in results])
    print(f"| CPU time per video (s) median / max (decode + perceive; what an unloaded core would take) | {np.median(cpus):.2f} / {cpus.max():.2f} | <= 3 / <= 8 |")
    built = [r for r in results if r.get("fit_cpu_s") is not None]
    if built and len(built) == len(results) - len(refused):
        fits = np.array([r["fit_cpu_s"] for r in built])
        builds = np.array([r["cpu_s"] for r in built]) + fits
        print(f"| fit CPU time per video (s) median / max (identify + world document) | {np.median(fits):.2f} / {fits.max():.2f} | |")
        print(f"| build CPU time per video (s) median / max (decode + perceive + fit, `physmind build`) | {np.median(builds):.2f} / {builds.max():.2f} | median <= 5 |")
    if not args.from_json:
        print(f"| machine load average (1, 5, 15 min) at the end | {' '.join(f'{x:.1f}' for x in os.getloadavg())} | 2 cores |")
    by_floor: dict[str, list[dict]] = {}
    for r in results:
        by_floor.setdefault(r.get("condition") or _condition({"look": r.get("look") or {}}), []).append(r)
    if len(by_floor) > 1:
        print("\nper condition: | condition | videos | objects | recall | switches | colour | shape | material |\n|---|---|---|---|---|---|---|---|")
        for key, group in sorted(by_floor.items()):
            rec = (sum(r["recall"][0] for r in group), max(sum(r["recall"][1] for r in group), 1))
            acc = {k: np.mean([h for r in group for h in r["attributes"][k]] or [np.nan]) for k in ("color", "shape", "material")}
            print(f"| {key} | {len(group)} | {sum(r['objects'] for r in group)} | {rec[0] / rec[1]:.3f} | {sum(r['switches'] for r in group)} "
                  f"| {acc['color']:.3f} | {acc['shape']:.3f} | {acc['material']:.3f} |")
    timed = [r for r in results if r["timings"]]
    stage = {k: np.median([r["timings"][k] for r in timed]) for k in (timed[0]["timings"] if timed else {})}
    print("| stage medians (s) | " + ", ".join(f"{k} {v:.2f}" for k, v in stage.items()) + " | |")
    if not args.no_e2e:
        print("\nend to end (identify -> score_world), summed over videos")
        print("| tracks | predictive F1 | counterfactual F1 | median RMSE (m) |\n|---|---|---|---|")
        for which in ("oracle", "perceived"):
            scored = [r for r in results if "e2e" in r]
            pred = [sum(r["e2e"][which]["predictive"][k] for r in scored) for k in range(3)]
            cf = [sum(r["e2e"][which]["counterfactual"][k] for r in scored) for k in range(3)]
            rmse = np.nanmedian([r["e2e"][which]["rmse"] for r in scored])
            print(f"| {which} | {_f1(*pred):.3f} | {_f1(*cf):.3f} | {rmse:.3f} |")
    worst = sorted(results, key=lambda r: (r["switches"] + r["fragmented"] + r["missed_objects"],
                                           -(r["recall"][0] / max(r["recall"][1], 1))), reverse=True)[: args.worst]
    print("\nweakest scenes: scene, recall, precision, switches, fragmented, missed objects, attribute misses")
    for r in worst:
        misses = {k: len(v) - sum(v) for k, v in r["attributes"].items() if k != "features"}
        print(f"  {r['scene']:5d} {r['recall'][0] / max(r['recall'][1], 1):.3f} {r['precision'][0] / max(r['precision'][1], 1):.3f} "
              f"{r['switches']} {r['fragmented']} {r['missed_objects']} {misses}")
    if args.json and not args.from_json:
        args.json.write_text(json.dumps(results, default=lambda o: o.tolist() if hasattr(o, "tolist") else float(o), indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
