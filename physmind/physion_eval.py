"""``physmind eval DIR`` on a Physion-layout directory (recognised by DIR/trials.json).

Per trial: read the annotation (oracle tracks), identify the latent
properties from the pre-curtain (or early) motion, carry them across the
curtain, continue the last phase from the prediction boundary in the 3D
analytic engine (``world.scene3d``) and answer "Will the red object contact
the yellow object?" from the engine's contact query. The HTTP tools
(check_contact) serve the 2D tabletop world only, so this path calls the 3D
engine directly. Prints per-category and overall per-scene accuracy in the
paper's Table 2 layout and writes one record per trial to the -o report.
"""

from __future__ import annotations

import argparse
import json
import re
import sys
import time
from concurrent.futures import as_completed
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from tqdm import tqdm

from physmind.executors import open_executor

from world.io import read_json_file
from world.scene3d.io import tracks_from_annotation, world3d_to_dict
from world.scene3d.predict import answer_contact

TABLE_COLUMNS: tuple[tuple[str, str], ...] = (
    ("friction_platform", "Fric. Plat."), ("friction_collision", "Fric. Coll."), ("bounce_platform", "Bounce Plat."),
    ("bounce_wall", "Bounce Wall"), ("mass_collision", "Mass Coll."),
)
PAPER_ROW = {"friction_platform": 57.29, "friction_collision": 64.06, "bounce_platform": 59.38, "bounce_wall": 64.06,
             "mass_collision": 54.69, "overall": 59.64}


CONTACT_QUESTION = re.compile(r"^\s*will the (\w+) (?:object|one|agent) (?:contact|touch|hit) the (\w+) (?:object|one|patient|zone|area)\s*\??\s*$", re.I)
ROLE_COLOURS = {"red": "agent", "yellow": "patient"}  # Physion++'s cues: red agent, yellow patient


def parse_contact_question(text: str | None) -> tuple[str, str]:
    """'Will the red object contact the yellow object?' -> ("agent", "patient"); ValueError otherwise."""
    match = CONTACT_QUESTION.match(text or "Will the red object contact the yellow object?")
    if not match:
        raise ValueError(f"question: not a contact question of the form 'Will the red object contact the yellow object?': {text!r}")
    roles = tuple(ROLE_COLOURS.get(colour.lower()) for colour in match.groups())
    if roles != ("agent", "patient"):
        raise ValueError(f"question: only the red agent and the yellow patient can be asked about, got {match.groups()}")
    return roles


def is_physion_dataset(path: Path) -> bool:
    return (Path(path) / "trials.json").is_file()


def normalise_category(name: str) -> str:
    """'Friction Platform', 'friction-platform', 'friction_platform' -> 'friction_platform'."""
    return "_".join(str(name).strip().lower().replace("-", " ").split())


def load_trials(directory: Path) -> list[dict[str, Any]]:
    trials = read_json_file(directory / "trials.json", "trials.json")
    if not isinstance(trials, list):
        raise ValueError(f"{directory / 'trials.json'}: expected a list of trials")
    for k, trial in enumerate(trials):
        if not isinstance(trial, dict) or "index" not in trial or "category" not in trial:
            raise ValueError(f"{directory / 'trials.json'}[{k}]: expected an object with 'index' and 'category'")
        if trial.get("label") is not None and not isinstance(trial["label"], bool):
            raise ValueError(f"{directory / 'trials.json'}[{k}].label: expected true, false or null")
    return trials


@dataclass(frozen=True)
class TrialRecord:
    index: int
    category: str
    label: bool | None
    prediction: bool | None
    contact_time: float | None = None
    closest_approach: float | None = None
    properties: dict | None = None
    evidence: str | None = None
    error: str | None = None
    seconds: float = 0.0
    world: dict | None = None  # the fitted 3D world (physion.schema.json#/$defs/world3d)

    def to_dict(self) -> dict[str, Any]:
        correct = None if self.label is None or self.prediction is None else self.label == self.prediction
        return {"index": self.index, "category": self.category, "label": self.label, "prediction": self.prediction,
                "correct": correct, "contact_time": self.contact_time, "closest_approach": self.closest_approach,
                "properties": self.properties, "evidence": self.evidence, "error": self.error,
                "seconds": round(self.seconds, 4), "world": self.world}


def _evidence(answer) -> str:
    fitted = ", ".join(f"{e.kind} of object {e.body_id}" + (f"/{e.other_id}" if e.other_id is not None else "")
                       + f" = {e.value:.3f} +- {e.std:.3f}" for e in answer.report.estimates) or "no property measured"
    outcome = (f"contact at t = {answer.time:.3f} s" if answer.contact
               else f"no contact; closest approach {answer.closest:.3f} m" if answer.closest is not None else "no contact")
    return f"{fitted}; {outcome}"


def evaluate_trial(directory: Path, trial: dict[str, Any]) -> TrialRecord:
    """Answer one trial from its annotation; errors become a record with ``error`` set (counted wrong)."""

    index, category = int(trial["index"]), normalise_category(trial["category"])
    started = time.perf_counter()
    try:
        parse_contact_question(trial.get("question"))
        document = read_json_file(directory / "annotations" / f"annotation_{index:05d}.json", "annotation")
        tracks, timing, states = tracks_from_annotation(document)
        answer = answer_contact(tracks, timing, states)
    except (ValueError, KeyError, TypeError, FileNotFoundError) as error:
        return TrialRecord(index, category, trial.get("label"), None, error=str(error),
                           seconds=time.perf_counter() - started)
    return TrialRecord(index, category, trial.get("label"), answer.contact, answer.time, answer.closest,
                       answer.report.to_dict(), _evidence(answer), seconds=time.perf_counter() - started,
                       world=world3d_to_dict(answer.world))


def evaluate_trials(directory: Path, trials: list[dict[str, Any]], workers: int = 1, dask: str | None = None,
                    progress: bool = True) -> list[TrialRecord]:
    """``evaluate_trial`` over ``trials``, in order: in this process, a local process pool (workers > 1)
    or on Dask (``dask``: 'local' or a scheduler address; physmind/executors.py)."""
    bar = tqdm(total=len(trials), desc="physion eval", unit="trial", disable=not progress)
    if workers <= 1 and dask is None:
        records = []
        for trial in trials:
            records.append(evaluate_trial(directory, trial))
            bar.update()
    else:
        with open_executor(dask, max(1, workers)) as executor:
            futures = {executor.submit(evaluate_trial, directory, trial): k for k, trial in enumerate(trials)}
            by_position: dict[int, TrialRecord] = {}
            for future in as_completed(futures):
                by_position[futures[future]] = future.result()
                bar.update()
        records = [by_position[k] for k in range(len(trials))]
    bar.close()
    return records


def accuracy_table(records: list[TrialRecord]) -> dict[str, tuple[int, int]]:
    """{category or 'overall': (correct, labelled trials)}; a failed trial counts as wrong."""
    table: dict[str, tuple[int, int]] = {}
    for key in [c for c, _ in TABLE_COLUMNS] + sorted({r.category for r in records} - {c for c, _ in TABLE_COLUMNS}) + ["overall"]:
        rows = [r for r in records if r.label is not None and (key == "overall" or r.category == key)]
        table[key] = (sum(r.prediction == r.label for r in rows), len(rows))
    return table


def format_table(table: dict[str, tuple[int, int]], label: str) -> str:
    keys = [c for c, _ in TABLE_COLUMNS] + [k for k in table if k not in dict(TABLE_COLUMNS) and k != "overall"] + ["overall"]
    titles = dict(TABLE_COLUMNS)
    lines = [f"{'method':<34}" + "".join(f"{titles.get(k, k.capitalize()):>14}" for k in keys)]

    def cell(key: str) -> str:
        correct, total = table.get(key, (0, 0))
        return f"{'-':>14}" if total == 0 else f"{100.0 * correct / total:>14.2f}"

    lines.append(f"{label:<34}" + "".join(cell(k) for k in keys))
    lines.append(f"{'PhysMind (paper, Physion++)':<34}" + "".join(
        f"{PAPER_ROW[k]:>14.2f}" if k in PAPER_ROW else f"{'-':>14}" for k in keys))
    lines.append(f"{'(trials)':<34}" + "".join(f"{table.get(k, (0, 0))[1]:>14d}" for k in keys))
    return "\n".join(lines)


def run_physion_eval(args: argparse.Namespace) -> int:
    """The handler ``physmind eval`` dispatches to when DATASET_DIR holds trials.json."""
    if args.source != "annotation":
        raise ValueError("--source video: not available for Physion-layout data yet (3D lifting from video is future "
                         "work); use --source annotation")
    if args.limit is not None and args.limit < 1:
        raise ValueError(f"--limit: expected >= 1, got {args.limit}")

    trials = load_trials(args.dataset)[: args.limit]
    if not trials:
        raise ValueError(f"{args.dataset}/trials.json holds no trials")
    records = evaluate_trials(args.dataset, trials, args.workers, args.dask)
    table = accuracy_table(records)
    print(format_table(table, "oracle tracks (3D analytic)"))
    for record in records:
        if record.error:
            print(f"trial {record.index}: failed: {record.error}", file=sys.stderr)
    report = {"label": "oracle tracks (3D analytic)", "dataset": str(args.dataset), "source": args.source,
              "accuracy": {k: (None if n == 0 else round(100.0 * c / n, 2)) for k, (c, n) in table.items()},
              "trials": [r.to_dict() for r in records],
              "seconds_per_trial": round(sum(r.seconds for r in records) / len(records), 4)}
    args.output.parent.mkdir(parents=True, exist_ok=True)
    args.output.write_text(json.dumps(report, indent=1))
    print(f"{len(records)} trials, {sum(r.error is not None for r in records)} failed; report -> {args.output}")
    return 0
