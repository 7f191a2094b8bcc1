"""Train and evaluate the material model (perception.material_model) across looks and renderers.

Usage:
  # samples first (one cache per generated set; bench.attribute_samples runs perception):
  MUJOCO_GL=egl python -m bench.attribute_samples DIR CACHE
  # per-object diagnosis of the shipped rules on each set:
  python -m bench.train_attributes diagnose NAME=CACHE [NAME=CACHE ...]
  # leave-one-set-out: train on all sets but one, test on it (and on --test sets, never trained on):
  python -m bench.train_attributes evaluate NAME=CACHE ... [--test NAME=CACHE ...]
  # colour and shape temperatures at minimum log loss over all sets:
  python -m bench.train_attributes calibrate NAME=CACHE ...
  # train on all sets and write the shipped parameters (--check: compare with the shipped file instead):
  python -m bench.train_attributes train NAME=CACHE ... [--out perception/data/material_model.json] [--check]

NAME tells the set's renderer and look family (e.g. mujoco-tune, povray-dev,
blender-31313); a name starting with the renderer (``mujoco`` / ``povray`` /
``blender``) lets ``evaluate`` also leave a whole renderer out. ``--kind``
chooses the model: ``trees`` (shipped; scikit-learn's gradient-boosted trees,
exported to JSON and evaluated with numpy at run time) or ``logistic``.
Deterministic: fixed random state, folds by scene.
"""

from __future__ import annotations

import argparse
import json
import math
import pickle
import sys
from pathlib import Path

import numpy as np
from scipy.optimize import minimize_scalar
from sklearn.ensemble import HistGradientBoostingClassifier
from sklearn.linear_model import LogisticRegression

from perception.attributes import (
    COLOR_TEMPERATURE,
    SHAPE_TEMPERATURE,
    ambiguous_weight,
    color_of_votes,
    color_probabilities,
    shape_probabilities,
)
from perception.material_model import (MODEL_PATH, TRACK_FEATURES, MaterialModel, TreeEnsemble, metal_probability, shape_one_hot,
                                       track_features)
from perception.pipeline import mean_overlaps, rank_shapes
from world.types import SHAPE_KINDS

REGULARISATION_C = 1.0  # inverse L2 strength of the logistic regression on standardised features
TREE_DEPTH = 3  # boosted trees: depth of each tree (interactions of up to three cues) ...
TREE_COUNT = 300  # ... number of boosting rounds ...
TREE_LEARNING_RATE = 0.05  # ... shrinkage per round ...
TREE_L2 = 1.0  # ... and L2 regularisation of the leaf values
CHECK_TOLERANCE = 1e-6  # largest parameter difference `train --check` accepts


def load_set(name: str, cache: Path) -> list[dict]:
    """Samples of one cache with a true object: dicts with set, scene, decided colour / shape, truth, windows, ..."""
    rows = []
    for path in sorted(cache.glob("*.pkl")):
        scene = pickle.loads(path.read_bytes())
        for track in scene["tracks"]:
            if track["truth"] is None:
                continue
            shape, _, _ = rank_shapes(track["shape_scores"])
            color = color_of_votes(track["color_votes"])
            rows.append({"set": name, "scene": f"{name}/{scene['scene']}", "color": color, "shape": shape,
                         "features": track_features(track["windows"], color),  # once: every split reuses them
                         **{k: v for k, v in track.items() if k != "track"}})
    return rows


def parse_sets(specs: list[str]) -> list[dict]:
    rows = []
    for spec in specs:
        name, _, cache = spec.partition("=")
        if not cache or not Path(cache).is_dir():
            raise SystemExit(f"{spec}: expected NAME=CACHE_DIR (an existing directory)")
        rows += load_set(name, Path(cache))
    return rows


def design(rows: list[dict]) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[dict]]:
    """(X (N, F) features, S (N, 3) shape one-hot, y (N,) 1 = metal, rows kept): tracks with features."""
    features, shapes, labels, kept = [], [], [], []
    for row in rows:
        f = row["features"]
        if f is None:
            continue
        features.append(f)
        shapes.append(shape_one_hot(row["shape"]))
        labels.append(row["truth"]["material"] == "metal")
        kept.append(row)
    return np.asarray(features), np.asarray(shapes, float), np.asarray(labels, float), kept


def renderer_weights(sets: list[str]) -> np.ndarray:
    """(N,) sample weights under which each renderer (the set name's prefix before '-') weighs the same in
    total, mean 1: a model that learns the renderer with most samples' cues does not carry over to the others
    (leave-one-renderer-out, docs/benchmarks.md "Twenty-sixth round")."""
    renderers = np.array([name.split("-")[0] for name in sets])
    weights = np.ones(len(renderers))
    for renderer in set(renderers):
        mine = renderers == renderer
        weights[mine] = len(renderers) / (len(set(renderers)) * mine.sum())
    return weights


def fit(x: np.ndarray, s: np.ndarray, y: np.ndarray, temperature: float = 1.0, kind: str = "trees",
        weights: np.ndarray | None = None) -> MaterialModel:
    """The model on standardised features and the shape one-hot (weights: (N,) per sample, renderer_weights):
    boosted trees (``trees``, the shipped kind: the cues interact with the look, e.g. a washed-out top is metal
    only where the light's mirror image meets the camera) or a logistic regression with a bias per shape
    (``logistic``)."""
    mean, scale = x.mean(axis=0), np.maximum(x.std(axis=0), 1e-6)
    inputs = np.hstack([(x - mean) / scale, s])
    if kind == "trees":
        boosted = HistGradientBoostingClassifier(max_depth=TREE_DEPTH, learning_rate=TREE_LEARNING_RATE, max_iter=TREE_COUNT,
                                                 l2_regularization=TREE_L2, early_stopping=False, random_state=0)
        boosted.fit(inputs, y.astype(int), sample_weight=weights)
        return MaterialModel(TRACK_FEATURES, mean, scale, None, None, temperature, exported_trees(boosted))
    if kind != "logistic":
        raise ValueError(f"kind: expected trees or logistic, got {kind!r}")
    regression = LogisticRegression(C=REGULARISATION_C, fit_intercept=False, max_iter=5000, tol=1e-10)
    regression.fit(inputs, y.astype(int), sample_weight=weights)
    coef = regression.coef_[0]
    return MaterialModel(TRACK_FEATURES, mean, scale, coef[: x.shape[1]], dict(zip(SHAPE_KINDS, (float(b) for b in coef[x.shape[1]:]))), temperature)


def exported_trees(boosted: HistGradientBoostingClassifier) -> TreeEnsemble:
    """A fitted binary HistGradientBoostingClassifier's trees as perception.material_model.TreeEnsemble (its
    decision_function, without scikit-learn at run time)."""
    parts, roots, offset = [], [], 0
    for (predictor,) in boosted._predictors:  # one tree per boosting round (binary: one class column)
        nodes = predictor.nodes
        if np.any(nodes["is_categorical"]):
            raise ValueError("exported_trees: categorical splits are not supported")
        roots.append(offset)
        leaf = nodes["is_leaf"].astype(bool)
        parts.append((np.where(leaf, -1, nodes["feature_idx"]), nodes["num_threshold"], nodes["missing_go_to_left"].astype(bool),
                      np.where(leaf, -1, nodes["left"] + offset), np.where(leaf, -1, nodes["right"] + offset),
                      np.where(leaf, nodes["value"], 0.0)))
        offset += len(nodes)
    feature, threshold, missing_left, left, right, value = (np.concatenate(column) for column in zip(*parts))
    return TreeEnsemble(float(np.ravel(boosted._baseline_prediction)[0]), feature.astype(np.int64), threshold.astype(float),
                        missing_left, left.astype(np.int64), right.astype(np.int64), value.astype(float), np.asarray(roots, np.int64))


def log_odds(model: MaterialModel, x: np.ndarray, s: np.ndarray) -> np.ndarray:
    shapes = [SHAPE_KINDS[int(np.argmax(row))] for row in s]
    return np.array([model.log_odds(f, shape) for f, shape in zip(x, shapes)])


def log_loss(z: np.ndarray, y: np.ndarray) -> float:
    """Mean log loss of the true class from log-odds of class 1."""
    return float(np.mean(np.logaddexp(0.0, -np.where(y > 0.5, z, -z))))


def fitted_temperature(z: np.ndarray, y: np.ndarray) -> float:
    """Temperature dividing out-of-fold log-odds z at minimum log loss."""
    return float(minimize_scalar(lambda t: log_loss(z / t, y), bounds=(0.2, 10.0), method="bounded").x)


def out_of_fold(x, s, y, groups, folds: int = 5, kind: str = "trees", weights: np.ndarray | None = None) -> np.ndarray:
    """Log-odds of each sample from a model trained without its scene's fold (scenes dealt round-robin)."""
    scenes = sorted(set(groups))
    fold_of = {scene: k % folds for k, scene in enumerate(scenes)}
    fold = np.array([fold_of[g] for g in groups])
    z = np.zeros(len(y))
    for k in range(folds):
        test = fold == k
        z[test] = log_odds(fit(x[~test], s[~test], y[~test], kind=kind, weights=None if weights is None else weights[~test]),
                           x[test], s[test])
    return z


def trained_model(rows: list[dict], kind: str = "trees") -> MaterialModel:
    """The model on all rows, each renderer weighing the same (renderer_weights), its temperature fitted on
    5-fold out-of-scene log-odds."""
    x, s, y, kept = design(rows)
    weights = renderer_weights([r["set"] for r in kept])
    temperature = fitted_temperature(out_of_fold(x, s, y, [r["scene"] for r in kept], kind=kind, weights=weights), y)
    return fit(x, s, y, temperature, kind, weights)


def _report(label: str, z: np.ndarray, y: np.ndarray) -> str:
    return f"{label:<34} {len(y):>5} {np.mean((z > 0) == (y > 0.5)):>8.3f} {log_loss(z, y):>8.3f}"


def evaluate(rows: list[dict], tests: list[dict], kind: str = "trees") -> None:
    header = f"{'trained on -> tested on':<34} {'n':>5} {'accuracy':>8} {'log loss':>8}"
    print(header)
    names = sorted(set(r["set"] for r in rows))
    renderers = sorted(set(n.split("-")[0] for n in names))
    holdouts = [(n, lambda r, n=n: r["set"] == n) for n in names]
    if len(renderers) > 1:
        holdouts += [(f"{rn}*", lambda r, rn=rn: r["set"].split("-")[0] == rn) for rn in renderers]
    for label, held in holdouts:
        train = [r for r in rows if not held(r)]
        test = [r for r in rows if held(r)]
        model = trained_model(train, kind)
        x, s, y, _ = design(test)
        print(_report(f"all but {label} -> {label}", log_odds(model, x, s), y))
    if tests:
        model = trained_model(rows, kind)
        for name in sorted(set(r["set"] for r in tests)):
            x, s, y, _ = design([r for r in tests if r["set"] == name])
            print(_report(f"all -> {name}", log_odds(model, x, s), y))
        mujoco = [r for r in rows if r["set"].startswith("mujoco")]
        if mujoco and len(mujoco) < len(rows):
            model = trained_model(mujoco, kind)
            for name in sorted(set(r["set"] for r in tests)):
                x, s, y, _ = design([r for r in tests if r["set"] == name])
                print(_report(f"mujoco* -> {name}", log_odds(model, x, s), y))


def diagnose(rows: list[dict]) -> None:
    """Per set: colour / shape / material accuracy of the shipped rules and model on tracklets, and the misses."""
    print(f"{'set':<16} {'n':>4} {'colour':>7} {'shape':>7} {'material':>8}")
    for name in sorted(set(r["set"] for r in rows)):
        part = [r for r in rows if r["set"] == name]
        ok = {"color": 0, "shape": 0, "material": 0}
        misses = []
        for r in part:
            material = "metal" if metal_probability(r["windows"], r["color"], r["shape"]) > 0.5 else "rubber"
            decided = {"color": r["color"], "shape": r["shape"], "material": material}
            for key in ok:
                ok[key] += decided[key] == r["truth"][key]
            wrong = [f"{k} {r['truth'][k]}->{decided[k]}" for k in ok if decided[k] != r["truth"][k]]
            if wrong:
                misses.append(f"  {r['scene']} obj {r['truth']['object']} ({r['frames']} fr, {r['isolated']} isolated): " + ", ".join(wrong))
        print(f"{name:<16} {len(part):>4} {ok['color'] / len(part):>7.3f} {ok['shape'] / len(part):>7.3f} {ok['material'] / len(part):>8.3f}")
        print("\n".join(misses))


def recorded_shape_overlaps(row: dict) -> dict[str, float]:
    """Mean shape overlap per kind (perception.attributes.shape_overlap at the shipped weights of shadow-like
    pixels: a track voted grey takes the hue-less one) from the silhouette counts bench.attribute_samples
    recorded; the recorded fit overlaps where a kind has no counts."""
    counts = row.get("shape_counts") or {}
    if not all(counts.get(kind) for kind in SHAPE_KINDS):
        return mean_overlaps(row["shape_scores"])
    weight = ambiguous_weight(color_of_votes(np.asarray(row["color_votes"])) == "gray")
    return {kind: float(np.mean([hits / (area + floor + weight * ambiguous) for hits, floor, ambiguous, _, area in counts[kind]]))
            for kind in SHAPE_KINDS}


def calibrate(rows: list[dict]) -> None:
    """Colour and shape temperatures at minimum mean log loss of the true value over all rows, and per set
    the accuracy and log loss at the fitted and the shipped temperatures."""
    def losses(probability_of, temperature):
        return np.array([-np.log(max(probability_of(r, temperature), 1e-12)) for r in rows])

    def colour(r, temperature):
        return color_probabilities(r["color_votes"], temperature)[r["truth"]["color"]]

    def shape(r, temperature):
        return shape_probabilities(recorded_shape_overlaps(r), temperature)[r["truth"]["shape"]]

    sets = sorted(set(r["set"] for r in rows))
    for label, probability_of, shipped in (("colour", colour, COLOR_TEMPERATURE), ("shape", shape, SHAPE_TEMPERATURE)):
        fitted = float(minimize_scalar(lambda t: losses(probability_of, t).mean(), bounds=(0.005, 2.0), method="bounded").x)
        print(f"{label}: fitted temperature {fitted:.4f} (shipped {shipped})")
        for temperature in (fitted, shipped):
            per_set = losses(probability_of, temperature)
            print("  T %.4f " % temperature + ", ".join(f"{n} {np.mean([per_set[i] for i, r in enumerate(rows) if r['set'] == n]):.3f}" for n in sets))


def parameter_gap(a, b) -> float:
    """Largest absolute difference between two models' JSON documents (inf where their structure differs)."""
    if isinstance(a, dict) and isinstance(b, dict):
        return max((parameter_gap(a[k], b[k]) for k in a), default=0.0) if a.keys() == b.keys() else math.inf
    if isinstance(a, list) and isinstance(b, list):
        return max((parameter_gap(u, v) for u, v in zip(a, b)), default=0.0) if len(a) == len(b) else math.inf
    if isinstance(a, str) or isinstance(b, str):
        return 0.0 if a == b else math.inf
    return abs(float(a) - float(b))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("command", choices=("diagnose", "evaluate", "train", "calibrate"))
    parser.add_argument("sets", nargs="+", help="NAME=CACHE_DIR (bench.attribute_samples output)")
    parser.add_argument("--test", nargs="*", default=[], help="NAME=CACHE_DIR sets only tested on (evaluate)")
    parser.add_argument("--out", type=Path, default=MODEL_PATH)
    parser.add_argument("--check", action="store_true", help="train: compare with --out instead of writing it")
    parser.add_argument("--kind", choices=("trees", "logistic"), default="trees", help="evaluate / train: the model (shipped: trees)")
    args = parser.parse_args(argv)
    rows = parse_sets(args.sets)
    if args.command == "diagnose":
        diagnose(rows)
    elif args.command == "calibrate":
        calibrate(rows)
    elif args.command == "evaluate":
        evaluate(rows, parse_sets(args.test), args.kind)
    else:
        model = trained_model(rows, args.kind)
        if args.check:
            gap = parameter_gap(model.to_json(), json.loads(args.out.read_text()))
            print(f"largest parameter difference to {args.out}: {gap:.2e}")
            return 0 if gap <= CHECK_TOLERANCE else 1
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(json.dumps(model.to_json()) + "\n")
        print(f"wrote {args.out} (temperature {model.temperature:.3f}, {len(design(rows)[2])} tracks)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
