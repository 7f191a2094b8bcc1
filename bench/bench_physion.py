"""Physion-style contact prediction from oracle tracks: accuracy and latent-property error per category.

Input: a dataset written by ``physmind synth --suite physion`` (annotations =
oracle tracks; ground_truth = MuJoCo's truth). Per trial: identify, register
the world on a local tool server and answer through the tools
(``physmind.physion_eval.evaluate_trials``, the same path as ``physmind eval``:
get_world_summary, continue_world, check_contact), then compare the fitted
latent property with the truth:

* friction: the agent's Coulomb coefficient (MuJoCo's parameter; Coulomb
  sliding realises it exactly);
* mass ratio: blue probe mass / red agent mass (momentum is exact);
* restitution: the median of the restitutions MuJoCo's soft contact realised
  at the agent's static impacts before the prediction boundary (the evidence;
  ``realised_restitution``); for reference also against the median over all
  its impacts (including the continuation) and against the nominal contact
  parameter (MuJoCo realises e within about +-0.05 of it, speed dependent).

Prints per category: accuracy, label-flip share of the trials, the share of
trials whose property is within the target (10 %; mass ratio 20 %), the
median relative error, and the number of trials without a property fit.

Usage:
    python -m bench.bench_physion DATASET_DIR [--limit N] [--workers N]
"""

from __future__ import annotations

import argparse
import statistics
from pathlib import Path

from physmind.local_server import local_server
from physmind.physion_eval import TABLE_COLUMNS, evaluate_trials, load_trials
from world.io import read_json_file

TARGETS = {"friction": 0.10, "restitution": 0.10, "mass": 0.20}
ESTIMATE_KIND = {"friction": "friction", "restitution": "restitution", "mass": "mass_ratio"}


def property_error(record, truth: dict) -> tuple[float | None, float | None]:
    """Relative error of the fitted latent property against the truth and (restitution) the nominal value."""
    prop = truth["property"]
    kind = prop["kind"]
    estimates = (record.properties or {}).get("estimates", [])
    if kind == "mass":
        agent = next(o for o in truth["objects"] if o["role"] == "agent")
        fitted = [e for e in estimates if e["kind"] == "mass_ratio" and {e["object_id"], e["other_object_id"]} == {agent["object_id"], prop["object_id"]}]
        if not fitted:
            return None, None
        e = fitted[0]
        value = e["value"] if e["object_id"] == agent["object_id"] else 1.0 / e["value"]
        target = prop["value"] / agent["mass"]
        return abs(value - target) / target, None
    fitted = [e for e in estimates if e["kind"] == ESTIMATE_KIND[kind] and e["object_id"] == prop["object_id"]]
    if not fitted:
        return None, None
    value = fitted[0]["value"]
    if kind == "restitution":
        impacts = truth["realised_restitution"]["impacts"]
        boundary = truth["boundary_time"]  # added by main() from the annotation
        seen = statistics.median([i["restitution"] for i in impacts if i["time"] <= boundary])
        every = truth["realised_restitution"]["median"]
        return abs(value - seen) / seen, (abs(value - every) / every, abs(value - prop["value"]) / prop["value"])
    return abs(value - prop["value"]) / prop["value"], None


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("dataset", type=Path)
    parser.add_argument("--limit", type=int, default=None)
    parser.add_argument("--workers", type=int, default=1, help="processes fitting the worlds")
    args = parser.parse_args()
    trials = load_trials(args.dataset)[: args.limit]
    rows: dict[str, list] = {}
    with local_server() as url:
        records = evaluate_trials(args.dataset, trials, url, args.workers, progress=True)
    failed = [r for r in records if r.error]
    for record in failed:
        print(f"trial {record.index}: failed: {record.error}")
    for record in records:
        truth = read_json_file(args.dataset / "ground_truth" / f"trial_{record.index:05d}.json", "ground truth")
        annotation = read_json_file(args.dataset / "annotations" / f"annotation_{record.index:05d}.json", "annotation")
        truth["boundary_time"] = annotation["prediction_boundary_frame"] / annotation["fps"]
        error, nominal_error = property_error(record, truth)
        rows.setdefault(record.category, []).append((record, truth, error, nominal_error))
    header = (f"{'category':<20}{'trials':>7}{'acc %':>8}{'flips %':>9}{'prop':>13}{'within %':>10}"
              f"{'med err %':>11}{'p90 err %':>11}{'no fit':>8}{'all-impacts / nominal med err %':>33}{'s/trial':>9}")
    print(header)
    all_records = []
    for category, _ in TABLE_COLUMNS:
        group = rows.get(category, [])
        if not group:
            continue
        all_records += group
        kind = group[0][1]["property"]["kind"]
        errors = [e for _, _, e, _ in group if e is not None]
        alternatives = [n for _, _, _, n in group if n is not None]
        within = sum(e <= TARGETS[kind] for e in errors)
        acc = 100.0 * sum(r.prediction == r.label for r, *_ in group) / len(group)
        flips = 100.0 * sum(t["label_flips"] for _, t, *_ in group) / len(group)
        p90 = sorted(errors)[int(0.9 * (len(errors) - 1))] if errors else float("nan")
        median = 100 * statistics.median(errors) if errors else float("nan")
        reference = (f"{100 * statistics.median(a for a, _ in alternatives):.2f} / {100 * statistics.median(b for _, b in alternatives):.2f}"
                     if alternatives else "-")
        seconds = statistics.mean(r.seconds for r, *_ in group)
        print(f"{category:<20}{len(group):>7}{acc:>8.2f}{flips:>9.1f}{kind:>13}{100.0 * within / len(group):>10.1f}"
              f"{median:>11.2f}{100 * p90:>11.2f}{len(group) - len(errors):>8}{reference:>33}{seconds:>9.3f}")
    acc = 100.0 * sum(r.prediction == r.label for r, *_ in all_records) / max(len(all_records), 1)
    print(f"{'overall':<20}{len(all_records):>7}{acc:>8.2f}")


if __name__ == "__main__":
    main()
