"""Identification accuracy and speed against MuJoCo ground truth.

Input: a dataset written by ``physmind synth`` (annotations = oracle tracks,
ground_truth = MuJoCo's future and counterfactual events). For each scene
and noise level: fit a world (``world.identify.fit.identify``), then score
it (``bench.metrics.score_world``):

* observed-window position RMSE over visible frames (median, p95);
* predictive: collisions after the video vs MuJoCo's future (5-frame
  tolerance), over all objects and over objects seen in the video;
* counterfactual: per removable object, F1 of the collision SET of our
  replay vs MuJoCo's re-simulation (mean over removals);
* wall time of the fit per scene;
* after the video (only when the dataset has ``future/`` from
  ``bench.oracle_dataset``): for objects seen in the video and still moving
  at its last frame (MuJoCo speed > STILL_MOVING_SPEED), the planar error at
  +1/+2/+3 s of the fitted world's factual continuation (median, p90, share
  within 10 cm), and in the same run of two baselines from the tracks the fit
  saw: holding the last observed position, and constant velocity (least
  squares over the last VELOCITY_WINDOW visible frames).

``--worlds DIR`` scores the noiseless analytic worlds already fitted by
``bench/bench_qa.py --cache`` (``DIR/world_XXXXX.json``, same identification
code, same oracle tracks) instead of fitting them again; their fit time is
the one recorded in the world's fit report.

``--forward-jacobian`` also fits with a forward-difference Jacobian every
iteration (the A/B of the secant Jacobian), in the same run. A second table
gives the fit cost: wall and CPU seconds, rollouts, budget hits.

``--budget S`` also fits with a joint-refinement budget of S CPU seconds
(``FitConfig.time_budget_seconds``), in the same run.

``--baseline`` also fits with the fixed-step integrator of the same model
(``bench.fixed_step``, dt = 1/100 s) and the same optimiser, in the same run.

Usage:
    python -m bench.bench_identify DATASET_DIR [--scenes N] [--noise 0,0.01,0.03]
        [--baseline] [--workers 2] [--worlds CACHE/annotation]
"""

from __future__ import annotations

import argparse
import json
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from bench.fixed_step import simulate_fixed_step
from bench.metrics import GroundTruth, PrecisionRecall, match_events, rollout_collisions, score_world
from bench.runner import dataset_annotations, print_and_save, run_with_progress
from world.identify.fit import FitConfig, identify
from world.io import world_from_dict
from world.observations import Observations
from world.rollout import simulate

OBJECT_SIZE = 0.4  # m, side / diameter of the generator's objects: noise is a share of it
AHEAD_SECONDS = (1.0, 2.0, 3.0)  # s after the last observed frame
STILL_MOVING_SPEED = 0.02  # m/s: MuJoCo speed at the last observed frame above which an object "still moves"
VELOCITY_WINDOW = 5  # frames: the constant-velocity baseline's least-squares window
NEAR_METRES = 0.10  # "within 10 cm"
PREDICTORS = ("world", "hold", "const-vel")
ROLLING_SPHERES = "roll-spheres"  # the same fit with spheres that skid then roll (FitConfig(rolling_spheres=True))
FORWARD_JACOBIAN = "fd-jacobian"  # the same fit with a forward-difference Jacobian every iteration (FitConfig(secant_jacobian=False))
FRICTIONLESS = "frictionless"  # the same fit without friction between bodies (FitConfig(friction_between_bodies=False))
BUDGET = "budget-"  # + CPU seconds: the same fit with FitConfig(time_budget_seconds=...) (--budget)


def _future_truth(annotation: Path, index: str) -> dict | None:
    path = annotation.parent.parent / "future" / f"scene_{index}.json"
    return json.loads(path.read_text()) if path.exists() else None


def _ahead_errors(world, observations: Observations, future: dict, score_simulator) -> dict[str, list[list[float]]]:
    """Planar errors (m) per predictor and per AHEAD_SECONDS of the objects still moving after the video."""
    fps, observed = float(future["fps"]), int(future["observed_frames"])
    truth = np.asarray(future["positions"], dtype=float)  # (T, N, 3)
    last = observed - 1
    steps = [int(round(a * fps)) for a in AHEAD_SECONDS]
    rollout = score_simulator(world, (), min(truth.shape[0], last + max(steps) + 1))
    column = {body: k for k, body in enumerate(rollout.body_ids)}
    tracks = {t.id: t for t in observations.objects}
    errors: dict[str, list[list[float]]] = {p: [[] for _ in steps] for p in PREDICTORS}
    for k, object_id in enumerate(future["object_ids"]):
        track = tracks.get(object_id)
        speed = np.linalg.norm(truth[last, k, :2] - truth[last - 1, k, :2]) * fps
        if track is None or speed <= STILL_MOVING_SPEED:
            continue
        seen = np.flatnonzero(track.visible[:observed])
        if seen.size < 2:
            continue
        window = seen[-VELOCITY_WINDOW:]
        times = (window - last) / fps
        velocity = np.polyfit(times, track.positions[window, :2], 1)[0] if window.size >= 2 else np.zeros(2)
        held = track.positions[seen[-1], :2]
        anchor_time = (seen[-1] - last) / fps
        for j, step in enumerate(steps):
            if last + step >= truth.shape[0]:
                continue
            actual = truth[last + step, k, :2]
            predicted = {
                "world": rollout.positions[last + step, column[object_id], :2] if object_id in column else held,
                "hold": held,
                "const-vel": held + velocity * (step / fps - anchor_time),
            }
            for name, position in predicted.items():
                errors[name][j].append(float(np.linalg.norm(position - actual)))
    return errors


def _noisy(observations: Observations, sigma: float, seed: int) -> Observations:
    """Add N(0, sigma) metres to every observed x and y (z untouched)."""
    if sigma == 0:
        return observations
    rng = np.random.default_rng(seed)
    tracks = []
    for track in observations.objects:
        noise = rng.normal(0.0, sigma, track.positions.shape)
        noise[:, 2] = 0.0
        tracks.append(replace(track, positions=track.positions + noise))
    return replace(observations, objects=tuple(tracks))


def _simulator(method: str):
    if method in ("analytic", ROLLING_SPHERES, FORWARD_JACOBIAN, FRICTIONLESS) or method.startswith(BUDGET):
        return None, lambda world, edits, horizon: simulate(world, edits, horizon)

    def stepper(world, edits, horizon):
        return simulate_fixed_step(world, edits, horizon, dt=0.01)

    return stepper, stepper


def evaluate(task: tuple[Path, float, str, Path | None]) -> dict:
    """Fit and score one (scene, noise, method); a failure is a row too, never a crash."""
    annotation, noise, method, worlds = task
    try:
        return _evaluate(annotation, noise, method, worlds)
    except Exception as error:  # noqa: BLE001 - the table reports failures
        index = int(annotation.stem.split("_")[-1])
        return {"scene": index, "noise": noise, "method": method, "error": f"{type(error).__name__}: {error}"}


def _cached_world(worlds: Path | None, index: str, noise: float, method: str):
    """(world, fit seconds, rollouts, CPU seconds or NaN) of a world bench_qa already fitted, or None."""
    if worlds is None or noise != 0 or method != "analytic":
        return None
    path = worlds / f"world_{index}.json"
    if not path.is_file():
        return None
    world = world_from_dict(json.loads(path.read_text()))
    fit = world.provenance["fit"]
    return world, float(fit["seconds"]), int(fit["function_evaluations"]), float(fit.get("cpu_seconds", "nan"))


def _evaluate(annotation: Path, noise: float, method: str, worlds: Path | None = None) -> dict:
    """Fit and score one (scene, noise, method); returns plain numbers."""
    index = annotation.stem.split("_")[-1]
    truth = GroundTruth.load(annotation.parent.parent / "ground_truth" / f"scene_{index}.json")
    clean = Observations.from_clevrer_annotation(annotation, camera=truth.camera)
    observations = _noisy(clean, noise * OBJECT_SIZE, seed=int(index))
    fit_simulator, score_simulator = _simulator(method)
    cached = _cached_world(worlds, index, noise, method)
    if cached is None:
        began, began_cpu = time.perf_counter(), time.process_time()
        config = FitConfig(simulator=fit_simulator, rolling_spheres=method == ROLLING_SPHERES,
                           secant_jacobian=method != FORWARD_JACOBIAN, friction_between_bodies=method != FRICTIONLESS)
        if method.startswith(BUDGET):
            config = replace(config, time_budget_seconds=float(method[len(BUDGET):]))
        world, report = identify(observations, config)
        seconds, evaluations = time.perf_counter() - began, report.function_evaluations
        cpu_seconds, budget_hit = time.process_time() - began_cpu, report.budget_exhausted
    else:
        world, seconds, evaluations, cpu_seconds = cached
        budget_hit = bool(world.provenance["fit"].get("budget_exhausted", False))
    visible = np.stack([t.visible for t in clean.objects], axis=1)
    # Each method executes its own fitted world, as its user would.
    score = score_world(world, truth, score_simulator, visible)
    seen = {t.id for t in clean.objects if t.visible.any()}
    base = score_simulator(world, (), truth.horizon_frames)
    future_seen = [c for c in truth.collisions if c[1] >= truth.observed_frames and set(c[0]) <= seen]
    predictive_seen = match_events(rollout_collisions(base, truth.observed_frames), future_seen)
    future = _future_truth(annotation, index)
    ahead = None if future is None else _ahead_errors(world, observations, future, score_simulator)
    # The collisions the world keeps as observed (identification's), against MuJoCo's in the video.
    observed_end = truth.observed_frames - 1
    kept_events = [((a, b), frame) for a, b, frame in world.observed_collisions or ()]
    kept = match_events(kept_events, [c for c in truth.collisions if c[1] <= observed_end])
    # ... and whether the fitted replay reproduces each collision the track analysis found
    # (the fit report's collisions_used; recall = reproduced / found).
    found = [((min(a, b), max(a, b)), frame) for a, b, frame in world.provenance.get("fit", {}).get("collisions_used", [])
             if frame <= observed_end]
    reproduced = match_events(rollout_collisions(base, 0, observed_end), found)
    return {
        "ahead": ahead,
        "kept": kept.counts(),
        "reproduced": reproduced.counts(),
        "scene": int(index),
        "noise": noise,
        "method": method,
        "rmse": score.rmse,
        "predictive": score.predictive.counts(),
        "predictive_seen": predictive_seen.counts(),
        "observed": score.observed.counts(),
        "counterfactual_f1": [c.f1 for c in score.counterfactual],
        "counterfactual": [c.counts() for c in score.counterfactual],
        "seconds": seconds,
        "cpu_seconds": cpu_seconds,
        "budget_exhausted": budget_hit,
        "evaluations": evaluations,
    }


def _sum(rows: list[dict], key: str) -> PrecisionRecall:
    total = PrecisionRecall(0, 0, 0)
    for row in rows:
        total = total + PrecisionRecall(*row[key])
    return total


def summarise(rows: list[dict]) -> list[str]:
    header = (
        f"{'method':<11} {'noise':>5} {'scenes':>7}| {'RMSE med':>8} {'p95':>6} (cm) | "
        f"{'pred P':>6} {'R':>5} {'F1':>5} | {'F1 seen':>7} | {'CF F1':>5} {'micro':>5} | "
        f"{'obs F1':>6} {'R':>5} | {'kept P':>6} {'R':>5} | {'replay R':>8} | {'fit s med':>9} {'p95':>6} {'max':>6}"
    )
    lines = [header, "-" * len(header)]
    groups: dict[tuple[str, float], list[dict]] = {}
    for row in rows:
        groups.setdefault((row["method"], row["noise"]), []).append(row)
    for (method, noise), everything in sorted(groups.items()):
        group = [r for r in everything if "error" not in r]
        failed = len(everything) - len(group)
        rmse = np.array([r["rmse"] for r in group]) * 100
        seconds = np.array([r["seconds"] for r in group])
        predictive, seen, observed = _sum(group, "predictive"), _sum(group, "predictive_seen"), _sum(group, "observed")
        kept, reproduced = _sum(group, "kept"), _sum(group, "reproduced")
        cf = [f for r in group for f in r["counterfactual_f1"]]
        cf_micro = PrecisionRecall(0, 0, 0)
        for r in group:
            for c in r["counterfactual"]:
                cf_micro = cf_micro + PrecisionRecall(*c)
        lines.append(
            f"{method:<11} {noise * 100:>4.0f}% {len(group):>4}{'' if not failed else f'+{failed}F':<3}| {np.nanmedian(rmse):>8.2f} {np.nanpercentile(rmse, 95):>6.2f}      | "
            f"{predictive.precision:>6.3f} {predictive.recall:>5.3f} {predictive.f1:>5.3f} | {seen.f1:>7.3f} | "
            f"{np.mean(cf):>5.3f} {cf_micro.f1:>5.3f} | {observed.f1:>6.3f} {observed.recall:>5.3f} | "
            f"{kept.precision:>6.3f} {kept.recall:>5.3f} | {reproduced.recall:>8.3f} | "
            f"{np.median(seconds):>9.2f} {np.percentile(seconds, 95):>6.2f} {np.max(seconds):>6.2f}"
        )
    lines += _cost_table(rows)
    lines += _ahead_table(rows)
    failures = [r for r in rows if "error" in r]
    if failures:
        lines.append(f"failed fits ('F' above): {len(failures)}")
        lines += [f"  scene {r['scene']} noise {r['noise']} {r['method']}: {r['error']}" for r in failures[:10]]
    return lines


def _cost_table(rows: list[dict]) -> list[str]:
    """Fit cost per method and noise: wall and CPU seconds (median / p95 / max), rollouts, budget hits.

    CPU seconds (the fitting process's own) stay meaningful on a shared,
    loaded machine where wall time measures the load as much as the fit.
    """
    groups: dict[tuple[str, float], list[dict]] = {}
    for row in rows:
        if "error" not in row:
            groups.setdefault((row["method"], row["noise"]), []).append(row)
    lines = ["", "fit cost per scene",
             f"{'method':<11} {'noise':>5} {'scenes':>6} | {'wall s med':>10} {'p95':>6} {'max':>6} | "
             f"{'CPU s med':>9} {'p95':>6} {'max':>6} | {'rollouts med':>12} {'max':>6} | {'budget hit':>10}"]
    for (method, noise), group in sorted(groups.items()):
        wall = np.array([r["seconds"] for r in group])
        cpu = np.array([r.get("cpu_seconds", np.nan) for r in group], dtype=float)
        rollouts = np.array([r["evaluations"] for r in group])
        hits = sum(bool(r.get("budget_exhausted")) for r in group)
        cpu_cells = (f"{'n/a':>9} {'':>6} {'':>6}" if np.all(np.isnan(cpu)) else
                     f"{np.nanmedian(cpu):>9.2f} {np.nanpercentile(cpu, 95):>6.2f} {np.nanmax(cpu):>6.2f}")
        lines.append(
            f"{method:<11} {noise * 100:>4.0f}% {len(group):>6} | {np.median(wall):>10.2f} {np.percentile(wall, 95):>6.2f} "
            f"{np.max(wall):>6.2f} | {cpu_cells} | {np.median(rollouts):>12.0f} {np.max(rollouts):>6d} | {hits:>10d}"
        )
    return lines


def _ahead_table(rows: list[dict]) -> list[str]:
    """Planar error after the video per predictor: median / p90 (cm) and share within 10 cm, per horizon."""
    groups: dict[tuple[str, float], list[dict]] = {}
    for row in rows:
        if row.get("ahead"):
            groups.setdefault((row["method"], row["noise"]), []).append(row)
    if not groups:
        return []
    cells = " | ".join(f"+{a:.0f} s med  p90  <10cm" for a in AHEAD_SECONDS)
    lines = ["", "objects still moving after the video: planar error (cm)",
             f"{'method':<11} {'noise':>5} {'predictor':<9} {'objects':>7} | {cells}"]
    for (method, noise), group in sorted(groups.items()):
        for predictor in PREDICTORS:
            parts = []
            count = 0
            for j in range(len(AHEAD_SECONDS)):
                values = np.array([e for r in group for e in r["ahead"][predictor][j]]) * 100
                count = max(count, values.size)
                parts.append("       n/a        " if values.size == 0 else
                             f"{np.median(values):>8.1f} {np.percentile(values, 90):>5.1f} {np.mean(values <= NEAR_METRES * 100) * 100:>4.0f}%")
            lines.append(f"{method:<11} {noise * 100:>4.0f}% {predictor:<9} {count:>7} | " + " | ".join(parts))
    return lines


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("dataset", type=Path, help="directory written by physmind synth")
    parser.add_argument("--scenes", type=int, default=None, help="use the first N scenes (default: all)")
    parser.add_argument("--noise", default="0,0.01,0.03", help="position noise levels, share of object size")
    parser.add_argument("--baseline", action="store_true", help="also fit with the fixed-step integrator")
    parser.add_argument("--baseline-scenes", type=int, default=None, help="limit the baseline to the first N scenes")
    parser.add_argument("--rolling-spheres", action="store_true",
                        help="also fit with spheres that skid then roll (FitConfig(rolling_spheres=True)), same run")
    parser.add_argument("--forward-jacobian", action="store_true",
                        help="also fit with a forward-difference Jacobian every iteration (FitConfig(secant_jacobian=False)), same run")
    parser.add_argument("--frictionless", action="store_true",
                        help="also fit without friction between bodies (FitConfig(friction_between_bodies=False)), same run")
    parser.add_argument("--budget", type=float, default=None,
                        help="also fit with FitConfig(time_budget_seconds=BUDGET) CPU seconds, same run (rows 'budget-S')")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--json", type=Path, help="write every per-scene row here")
    parser.add_argument("--worlds", type=Path, default=None,
                        help="score the noiseless worlds bench_qa --cache fitted (CACHE/annotation) instead of refitting them")
    args = parser.parse_args(argv)

    annotations = dataset_annotations(args.dataset, args.scenes)
    noises = [float(v) for v in args.noise.split(",")]
    tasks = [(a, noise, "analytic", args.worlds) for noise in noises for a in annotations]
    if args.rolling_spheres:
        tasks += [(a, noise, ROLLING_SPHERES, None) for noise in noises for a in annotations]
    if args.forward_jacobian:
        tasks += [(a, noise, FORWARD_JACOBIAN, None) for noise in noises for a in annotations]
    if args.frictionless:
        tasks += [(a, noise, FRICTIONLESS, None) for noise in noises for a in annotations]
    if args.budget is not None:
        tasks += [(a, noise, f"{BUDGET}{args.budget:g}", None) for noise in noises for a in annotations]
    if args.baseline:
        for a in annotations[: args.baseline_scenes]:
            tasks += [(a, noise, "fixed-1/100", None) for noise in noises]
    began = time.perf_counter()
    rows = run_with_progress(evaluate, tasks, args.workers, "fits")
    print(f"# {args.dataset}: {len(annotations)} scenes, {args.workers} workers, {time.perf_counter() - began:.0f} s")
    print_and_save(summarise(rows), rows, args.json)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
