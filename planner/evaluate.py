"""Evaluate the planner on a CLEVRER-layout dataset: build worlds, ask every question, score.

Scoring follows the paper's Table 1: an option is right when its verdict
equals the dataset's answer (an undecided option counts as wrong); a
question is right when all its options are. Accuracies are per question type
(explanatory, predictive, counterfactual) and overall.

Dataset layout (``physmind synth`` writes it; real CLEVRER has the first three):

    DIR/questions.json                  CLEVRER question list (or dict keyed by scene index)
    DIR/annotations/annotation_XXXXX.json   oracle tracks (source "annotation")
    DIR/videos/video_XXXXX.mp4          the video (source "video")
    DIR/ground_truth/scene_XXXXX.json   optional: its "camera" is used for in/out events
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterable, Mapping, Sequence

from tqdm import tqdm

from planner.answer import Answer
from planner.client import ToolCallError, ToolClient
from planner.executor import ExecutorConfig, VideoExecutor, answer_dataset_question, prediction_horizon_for, truth_of
from planner.parser import iter_videos
from world.io import read_json_file

QUESTION_TYPES: tuple[str, ...] = ("explanatory", "predictive", "counterfactual")


@dataclass(frozen=True)
class VideoEntry:
    """One video of a dataset: its scene index, questions and the files to build its world from."""

    scene_index: int
    questions: tuple[Mapping[str, Any], ...]
    annotation: Path
    video: Path
    camera_document: Mapping[str, Any] | None


def _scene_index(key: str, record: Mapping[str, Any]) -> int:
    value = record.get("scene_index", key)
    try:
        return int(value)
    except (TypeError, ValueError):
        raise ValueError(f"scene_index: expected an integer, got {value!r}") from None


def load_dataset(root: Path, camera_document: Mapping[str, Any] | None = None, limit: int | None = None) -> list[VideoEntry]:
    """The videos of a dataset directory with questions.json (see the module docstring).

    camera_document: used for every video without a ground_truth camera.

    Raises:
        FileNotFoundError: no directory or no questions.json.
        ValueError: questions.json is not a CLEVRER question file.
    """
    root = Path(root)
    if not root.is_dir():
        raise FileNotFoundError(f"dataset directory not found: {root}")

    document = read_json_file(root / "questions.json", "questions file")
    entries = []
    for key, record in iter_videos(document):
        index = _scene_index(key, record)
        camera = camera_document
        truth_path = root / "ground_truth" / f"scene_{index:05d}.json"
        if truth_path.is_file():
            camera = json.loads(truth_path.read_text()).get("camera", camera)
        entries.append(VideoEntry(index, tuple(record["questions"]), root / "annotations" / f"annotation_{index:05d}.json",
                                  root / "videos" / str(record.get("video_filename", f"video_{index:05d}.mp4")), camera))
    entries.sort(key=lambda e: e.scene_index)
    return entries[:limit] if limit is not None else entries


# -- asking and scoring --------------------------------------------------------------------


@dataclass(frozen=True)
class QuestionRecord:
    """One answered question with the dataset's truth."""

    scene_index: int
    question_id: Any
    question_type: str
    truth: tuple[str | None, ...]
    answer: Answer | None
    calls: tuple[dict[str, Any], ...] = ()
    error: str | None = None

    @property
    def verdicts(self) -> tuple[str | None, ...]:
        if self.answer is None:
            return tuple(None for _ in self.truth)
        return tuple(self.answer.verdicts)

    @property
    def options_right(self) -> int:
        return sum(1 for v, t in zip(self.verdicts, self.truth) if v is not None and v == t)

    @property
    def question_right(self) -> bool:
        return len(self.truth) > 0 and self.options_right == len(self.truth)

    def to_dict(self) -> dict[str, Any]:
        return {"scene_index": self.scene_index, "question_id": self.question_id, "question_type": self.question_type,
                "truth": list(self.truth), "verdicts": list(self.verdicts), "question_right": self.question_right,
                "answer": None if self.answer is None else self.answer.to_dict(), "tool_call_log": list(self.calls), "error": self.error}


def ask_video(client: ToolClient, world_document: Mapping[str, Any], entry: VideoEntry, config: ExecutorConfig,
              answer_fn: Callable[[VideoExecutor, Mapping[str, Any]], Answer] = answer_dataset_question) -> tuple[list[QuestionRecord], float]:
    """Register the world, answer every question of the video; returns records and the seconds spent answering."""
    started = time.perf_counter()
    handle = client.create_world(world_document, name=f"scene_{entry.scene_index:05d}",
                                 horizon_frames=prediction_horizon_for(world_document))
    executor = VideoExecutor(handle, config)
    records = []
    for question in entry.questions:
        try:
            answer = answer_fn(executor, question)
            error = answer.error
        except ToolCallError as failure:
            answer, error = None, str(failure)
        cited = tuple(handle.calls[i].to_dict() for i in (answer.tool_calls if answer else ()) if 0 <= i < len(handle.calls))
        records.append(QuestionRecord(entry.scene_index, question.get("question_id"), str(question.get("question_type")),
                                      tuple(truth_of(question)), answer, cited, error))
    return records, time.perf_counter() - started


@dataclass
class Tally:
    questions: int = 0
    questions_right: int = 0
    options: int = 0
    options_right: int = 0

    def add(self, record: QuestionRecord) -> None:
        self.questions += 1
        self.questions_right += int(record.question_right)
        self.options += len(record.truth)
        self.options_right += record.options_right

    @staticmethod
    def _pct(right: int, total: int) -> float | None:
        return None if total == 0 else 100.0 * right / total

    @property
    def per_question(self) -> float | None:
        return self._pct(self.questions_right, self.questions)

    @property
    def per_option(self) -> float | None:
        return self._pct(self.options_right, self.options)

    def to_dict(self) -> dict[str, Any]:
        return {"questions": self.questions, "questions_right": self.questions_right, "options": self.options,
                "options_right": self.options_right, "per_question": self.per_question, "per_option": self.per_option}


def accuracy(records: Iterable[QuestionRecord]) -> dict[str, Tally]:
    """Tallies per question type plus "overall"."""
    table = {kind: Tally() for kind in (*QUESTION_TYPES, "overall")}
    for record in records:
        table.setdefault(record.question_type, Tally()).add(record)
        table["overall"].add(record)
    return table


def format_table(rows: Mapping[str, Mapping[str, Tally]]) -> str:
    """The paper's Table 1 layout: one row per method, per-question / per-option accuracy (%) per type."""
    columns = (*QUESTION_TYPES, "overall")
    head1 = f"{'method':<34}" + "".join(f"{c.capitalize():^20}" for c in columns)
    head2 = f"{'':<34}" + "".join(f"{'per ques.':>10}{'per opt.':>10}" for _ in columns)
    lines = [head1, head2]

    def cell(value: float | None) -> str:
        return f"{'-':>10}" if value is None else f"{value:>10.2f}"

    for label, table in rows.items():
        lines.append(f"{label:<34}" + "".join(cell(table[c].per_question) + cell(table[c].per_option) for c in columns))
    counts = next(iter(rows.values()), None)
    if counts is not None:
        lines.append(f"{'(questions / options)':<34}" + "".join(f"{counts[c].questions:>10}{counts[c].options:>10}" for c in columns))
    return "\n".join(lines)


@dataclass
class EvalResult:
    records: list[QuestionRecord] = field(default_factory=list)
    build_info: dict[int, dict[str, Any]] = field(default_factory=dict)
    answer_seconds: dict[int, float] = field(default_factory=dict)

    def table(self) -> dict[str, Tally]:
        return accuracy(self.records)

    def to_dict(self, label: str, extra: Mapping[str, Any] | None = None) -> dict[str, Any]:
        questions = max(1, len(self.records))
        return {
            "label": label, **(extra or {}),
            "accuracy": {k: v.to_dict() for k, v in self.table().items()},
            "cost": {"videos": len(self.answer_seconds), "questions": len(self.records),
                     "answer_seconds_total": round(sum(self.answer_seconds.values()), 3),
                     "answer_seconds_per_question": round(sum(self.answer_seconds.values()) / questions, 4),
                     "build_seconds_per_video": _mean([i.get("seconds") for i in self.build_info.values() if not i.get("cached")])},
            "build": {str(k): v for k, v in sorted(self.build_info.items())},
            "answers": [r.to_dict() for r in self.records],
        }


def _mean(values: Iterable[Any]) -> float | None:
    numbers = [float(v) for v in values if isinstance(v, (int, float))]
    return None if not numbers else round(sum(numbers) / len(numbers), 3)


def evaluate(entries: Sequence[VideoEntry], worlds: Mapping[int, Mapping[str, Any]], client: ToolClient,
             config: ExecutorConfig, progress: bool = True, build_info: Mapping[int, dict[str, Any]] | None = None) -> EvalResult:
    """Ask every question of every video whose world was built; a video without a world scores all wrong."""
    result = EvalResult(build_info=dict(build_info or {}))
    for entry in tqdm(entries, desc=f"ask ({config.mode})", unit="video", disable=not progress):
        world = worlds.get(entry.scene_index)
        if world is None:
            reason = (build_info or {}).get(entry.scene_index, {}).get("error", "no world")
            for question in entry.questions:
                result.records.append(QuestionRecord(entry.scene_index, question.get("question_id"), str(question.get("question_type")),
                                                     tuple(truth_of(question)), None, (), f"no world: {reason}"))
            continue
        try:
            records, seconds = ask_video(client, world, entry, config)
        except ToolCallError as failure:  # e.g. the server refuses the world: its questions score wrong
            records, seconds = [QuestionRecord(entry.scene_index, question.get("question_id"), str(question.get("question_type")),
                                               tuple(truth_of(question)), None, (), f"world not served: {failure}")
                                for question in entry.questions], 0.0
        result.records.extend(records)
        result.answer_seconds[entry.scene_index] = seconds
    return result
