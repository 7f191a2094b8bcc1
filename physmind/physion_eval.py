"""``physmind eval DIR`` on a Physion-layout directory (recognised by DIR/trials.json).

Per trial: read the annotation (oracle tracks), identify the latent
properties from the pre-curtain (or early) motion, carry them across the
curtain and anchor the 3D world at the prediction boundary
(``world.scene3d.predict.fit_world``; ``--workers`` processes or ``--dask``, ``--cache``
keeps the fitted worlds). Then the question "Will the red object contact the
yellow object?" is parsed and answered THROUGH THE TOOLS over HTTP, as the
CLEVRER eval is: the world is registered (POST /v1/worlds), get_world_summary
grounds the red agent and the yellow patient (a body or the patient zone),
continue_world runs the factual continuation to the horizon and check_contact
answers on it; its evidence names the fitted property and the contact time or
the closest approach. A local server is started unless ``--server`` names one.
Prints per-category and overall per-scene accuracy in the paper's Table 2
layout and writes one record per trial (with its tool calls) to the -o report.
"""

from __future__ import annotations

import argparse
import json
import re
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterator

from tqdm import tqdm

from physmind.executors import run_jobs
from physmind.local_server import local_server
from planner.client import ToolCallError, ToolClient
from world.io import read_json_file
from world.scene3d.io import tracks_from_annotation, world3d_from_dict, world3d_to_dict
from world.scene3d.predict import fit_world

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
    tool_calls: tuple[dict, ...] = ()

    def to_dict(self) -> dict[str, Any]:
        correct = None if self.label is None or self.prediction is None else self.label == self.prediction
        return {"index": self.index, "category": self.category, "label": self.label, "prediction": self.prediction,
                "correct": correct, "contact_time": self.contact_time, "closest_approach": self.closest_approach,
                "properties": self.properties, "evidence": self.evidence, "error": self.error,
                "seconds": round(self.seconds, 4), "tool_calls": list(self.tool_calls), "world": self.world}


@dataclass(frozen=True)
class FittedTrial:
    """A trial's fitted world document (or the error that stopped the fit) and the fit's wall time (s)."""

    index: int
    category: str
    label: bool | None
    question: str | None
    world: dict | None
    error: str | None
    seconds: float


def world_cache_path(cache: Path, index: int) -> Path:
    return cache / f"world_{index:05d}.json"


def fit_trial(directory: Path, trial: dict[str, Any], cache: Path | None = None) -> FittedTrial:
    """Parse the question, read the annotation and fit the anchored 3D world (reused from ``cache`` when there)."""
    index, category = int(trial["index"]), normalise_category(trial["category"])
    started = time.perf_counter()
    try:
        parse_contact_question(trial.get("question"))
        cached = world_cache_path(cache, index) if cache is not None else None
        if cached is not None and cached.is_file():
            document = read_json_file(cached, "cached world")
            world3d_from_dict(document)  # a stale or foreign file fails here, not on the server
        else:
            annotation = read_json_file(directory / "annotations" / f"annotation_{index:05d}.json", "annotation")
            document = world3d_to_dict(fit_world(*tracks_from_annotation(annotation)).world)
            if cached is not None:
                cached.parent.mkdir(parents=True, exist_ok=True)
                cached.write_text(json.dumps(document))
    except (ValueError, KeyError, TypeError, FileNotFoundError) as error:
        return FittedTrial(index, category, trial.get("label"), trial.get("question"), None, str(error), time.perf_counter() - started)
    return FittedTrial(index, category, trial.get("label"), trial.get("question"), document, None, time.perf_counter() - started)


def fit_trials(directory: Path, trials: list[dict[str, Any]], workers: int = 1, cache: Path | None = None,
               progress: bool = False, dask: str | None = None) -> Iterator[tuple[int, FittedTrial]]:
    """(position in ``trials``, fitted world) as each fit finishes: in this process, ``workers`` > 1 local
    processes, or on Dask (``dask``: 'local' or a scheduler address; physmind/executors.py)."""
    results = run_jobs(fit_trial, [(directory, trial, cache) for trial in trials], workers, dask)
    with tqdm(total=len(trials), desc="physion fit", unit="trial", disable=not progress) as bar:
        for position, fitted, error in results:
            if error is not None:
                raise error
            yield position, fitted
            bar.update()


def ground_roles(summary: dict[str, Any], roles: tuple[str, str]) -> tuple[int, int]:
    """Object ids of the question's (agent, patient) from get_world_summary: the bodies with those roles,
    the patient zone standing in for a patient body. ValueError when the world has no such object."""
    by_role = {o.get("role"): o["object_id"] for o in summary["objects"] if o.get("role")}
    agent = by_role.get(roles[0])
    patient = summary.get("patient_zone") if summary.get("patient_zone") is not None else by_role.get(roles[1])
    if agent is None or patient is None:
        raise ValueError(f"the world has no {'red agent' if agent is None else 'yellow patient'} to ask about")
    return agent, patient


def answer_trial(client: ToolClient, fitted: FittedTrial) -> TrialRecord:
    """Register the fitted world and answer the trial's question through get_world_summary, continue_world
    and check_contact; the world is deleted afterwards. Errors become a record with ``error`` set."""
    started = time.perf_counter()
    if fitted.error is not None:
        return TrialRecord(fitted.index, fitted.category, fitted.label, None, error=fitted.error, seconds=fitted.seconds)
    handle = None
    try:
        roles = parse_contact_question(fitted.question)
        handle = client.create_world(fitted.world, name=f"physion trial {fitted.index}")
        summary = handle.call("get_world_summary")
        agent, patient = ground_roles(summary, roles)
        continued = handle.call("continue_world", horizon_frames=summary["default_horizon_frames"])
        result = handle.call("check_contact", object_a=agent, object_b=patient, rollout_id=continued["rollout_id"])
    except (ToolCallError, ValueError) as error:
        calls = tuple(c.to_dict() for c in handle.calls) if handle is not None else ()
        return TrialRecord(fitted.index, fitted.category, fitted.label, None, error=str(error), tool_calls=calls,
                           seconds=fitted.seconds + time.perf_counter() - started)
    finally:
        if handle is not None:
            client.delete_world(handle.world_id)
    return TrialRecord(fitted.index, fitted.category, fitted.label, bool(result["contact"]), result["contact_time"],
                       None if result["contact"] else result["nearest_distance"],
                       {"estimates": fitted.world["fitted_properties"]}, result["note"],
                       seconds=fitted.seconds + time.perf_counter() - started, world=fitted.world,
                       tool_calls=tuple(c.to_dict() for c in handle.calls))


def evaluate_trials(directory: Path, trials: list[dict[str, Any]], server_url: str, workers: int = 1,
                    cache: Path | None = None, progress: bool = False, dask: str | None = None) -> list[TrialRecord]:
    """Every trial fitted (``workers`` processes) and answered through the tools of the server at ``server_url``."""
    with ToolClient(server_url) as client:
        answered = {position: answer_trial(client, fitted)
                    for position, fitted in fit_trials(directory, trials, workers, cache, progress, dask)}
    return [answered[position] for position in range(len(trials))]


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


def check_physion_flags(args: argparse.Namespace) -> None:
    """ValueError (one line, exit 2) for a flag the Physion path cannot honour."""
    if args.source != "annotation":
        raise ValueError("--source video: not available for Physion-layout data yet (3D lifting from video is future "
                         "work); use --source annotation")
    if args.mode != "execute":
        raise ValueError(f"--mode {args.mode}: not defined for Physion-layout data (the answer is the executed contact "
                         "query of the fitted 3D world); use --mode execute")
    if args.camera is not None:
        raise ValueError("--camera: Physion-layout data carries its cameras in DIR/cameras/, and oracle tracks "
                         "(--source annotation) do not use them")
    if args.workers < 1:
        raise ValueError(f"--workers: expected >= 1, got {args.workers}")
    if args.limit is not None and args.limit < 1:
        raise ValueError(f"--limit: expected >= 1, got {args.limit}")
    if args.cache is not None and args.cache.exists() and not args.cache.is_dir():
        raise ValueError(f"--cache: {args.cache} exists and is not a directory")


def run_physion_eval(args: argparse.Namespace) -> int:
    """The handler ``physmind eval`` dispatches to when DATASET_DIR holds trials.json."""
    check_physion_flags(args)
    trials = load_trials(args.dataset)[: args.limit]
    if not trials:
        raise ValueError(f"{args.dataset}/trials.json holds no trials")
    if args.server:
        records = evaluate_trials(args.dataset, trials, args.server, args.workers, args.cache, True, args.dask)
    else:
        with local_server() as url:
            records = evaluate_trials(args.dataset, trials, url, args.workers, args.cache, True, args.dask)
    label = "oracle tracks (3D analytic, tools)"
    table = accuracy_table(records)
    print(format_table(table, label))
    for record in records:
        if record.error:
            print(f"trial {record.index}: failed: {record.error}", file=sys.stderr)
    report = {"label": label, "dataset": str(args.dataset), "source": args.source, "server": args.server or "local",
              "accuracy": {k: (None if n == 0 else round(100.0 * c / n, 2)) for k, (c, n) in table.items()},
              "trials": [r.to_dict() for r in records],
              "seconds_per_trial": round(sum(r.seconds for r in records) / len(records), 4)}
    args.output.parent.mkdir(parents=True, exist_ok=True)
    args.output.write_text(json.dumps(report, indent=1))
    print(f"{len(records)} trials, {sum(r.error is not None for r in records)} failed; report -> {args.output}")
    return 0
