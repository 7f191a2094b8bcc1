"""``physmind build / ask / eval`` and the accuracy of the executor on fitted fixture scenes.

The fixture worlds are fitted from the annotations' tracks (oracle tracks) by the
lead's identification, so the accuracy threshold below is for the current fit:
measured on fixture scenes 0-3 (19 questions, 60 options) when this test was
written: 14/19 questions, 49/60 options. Every remaining miss was traced to the
world (a collision the fit does not reproduce, an object never in view during the
128 observed frames), none to the executor.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from planner.answer import Answer, ChoiceAnswer
from planner.evaluate import QuestionRecord, accuracy, evaluate, format_table
from planner.executor import ExecutorConfig
from world.io import world_from_dict

REPO = Path(__file__).resolve().parents[2]
FIXTURES = REPO / "tests" / "data" / "synth"
MIN_OPTION_ACCURACY = 0.75
MIN_QUESTION_ACCURACY = 0.60
# The only reasons an option may stay undecided on fixture scenes.
UNDECIDED_REASONS = ("matches no object", "expected exactly one item, got 0", "ambiguous")


def _run(*arguments: str, timeout: float = 300) -> subprocess.CompletedProcess:
    env = {k: v for k, v in os.environ.items() if not k.startswith("PHYSMIND_API_KEY")}
    return subprocess.run([sys.executable, "-m", "physmind.cli", *arguments], capture_output=True, text=True, timeout=timeout, cwd=REPO, env=env)


def test_executor_accuracy_on_fitted_fixture_scenes(fitted_fixture_worlds, tool_client):
    entries, worlds, infos, _ = fitted_fixture_worlds
    assert set(worlds) == {e.scene_index for e in entries}, infos
    result = evaluate(entries, worlds, tool_client, ExecutorConfig(), progress=False)
    table = result.table()
    overall = table["overall"]
    print("\n" + format_table({"oracle tracks, fixture scenes 0-3": table}))
    assert overall.questions == sum(len(e.questions) for e in entries)
    assert overall.options_right / overall.options >= MIN_OPTION_ACCURACY
    assert overall.questions_right / overall.questions >= MIN_QUESTION_ACCURACY
    for record in result.records:
        for choice in record.answer.choices:
            if choice.verdict is None:
                assert any(reason in (choice.error or "") for reason in UNDECIDED_REASONS), choice


def test_accuracy_tally_counts_undecided_as_wrong():
    def record(kind, verdicts, truth):
        choices = tuple(ChoiceAnswer(k, "", None, v) for k, v in enumerate(verdicts))
        return QuestionRecord(0, 0, kind, tuple(truth), Answer("q", kind, None, choices))

    table = accuracy([record("explanatory", ["correct", "wrong"], ["correct", "wrong"]),
                      record("explanatory", ["correct", None], ["correct", "wrong"]),
                      record("predictive", ["wrong", "correct"], ["correct", "wrong"])])
    assert table["explanatory"].to_dict() == {"questions": 2, "questions_right": 1, "options": 4, "options_right": 3,
                                              "per_question": 50.0, "per_option": 75.0}
    assert (table["predictive"].per_question, table["predictive"].per_option) == (0.0, 0.0)
    assert table["counterfactual"].per_question is None
    assert (table["overall"].questions, table["overall"].options_right) == (3, 3)
    text = format_table({"row": table})
    assert "Explanatory" in text and "50.00" in text and "75.00" in text


def _tiny_dataset(root: Path, scenes: tuple[int, ...]) -> Path:
    """A copy of some fixture scenes in the CLEVRER layout (questions, annotations, ground truth)."""
    (root / "annotations").mkdir(parents=True)
    (root / "ground_truth").mkdir()
    questions = [v for v in json.loads((FIXTURES / "questions.json").read_text()) if v["scene_index"] in scenes]
    (root / "questions.json").write_text(json.dumps(questions))
    for index in scenes:
        shutil.copy(FIXTURES / "annotations" / f"annotation_{index:05d}.json", root / "annotations")
        shutil.copy(FIXTURES / "ground_truth" / f"scene_{index:05d}.json", root / "ground_truth")
    return root


def test_eval_command_prints_the_table_and_writes_every_answer(tmp_path, fitted_fixture_worlds):
    _, _, _, cache = fitted_fixture_worlds
    data = _tiny_dataset(tmp_path / "tiny", (1, 3))
    report_path = tmp_path / "report.json"
    completed = _run("eval", str(data), "--cache", str(cache), "-o", str(report_path))
    assert completed.returncode == 0, completed.stderr
    assert "Explanatory" in completed.stdout and "per ques." in completed.stdout and "oracle tracks (execute)" in completed.stdout
    report = json.loads(report_path.read_text())
    questions = [q for v in json.loads((data / "questions.json").read_text()) for q in v["questions"]]
    assert len(report["answers"]) == len(questions) == report["accuracy"]["overall"]["questions"]
    # The accuracies follow from the recorded verdicts and truths.
    right = sum(1 for a in report["answers"] for v, t in zip(a["verdicts"], a["truth"]) if v == t)
    assert report["accuracy"]["overall"]["options_right"] == right
    assert all(a["answer"]["tool_calls"] and a["tool_call_log"] for a in report["answers"])
    assert {a["question_type"] for a in report["answers"]} == {"explanatory", "predictive", "counterfactual"}
    table_line = next(line for line in completed.stdout.splitlines() if line.startswith("oracle tracks (execute)"))
    overall = report["accuracy"]["overall"]
    assert f"{overall['per_question']:.2f}" in table_line and f"{overall['per_option']:.2f}" in table_line


def test_eval_trajectory_only_mode_never_replays(tmp_path, fitted_fixture_worlds):
    _, _, _, cache = fitted_fixture_worlds
    data = _tiny_dataset(tmp_path / "tiny", (3,))
    report_path = tmp_path / "report.json"
    completed = _run("eval", str(data), "--cache", str(cache), "--mode", "trajectory_only", "-o", str(report_path))
    assert completed.returncode == 0, completed.stderr
    report = json.loads(report_path.read_text())
    tools = {c["tool"] for a in report["answers"] for c in a["tool_call_log"]}
    assert "compare_rollouts" not in tools
    assert not any(c["tool"] == "simulate_edit" and c["arguments"].get("edit_type") == "remove_object"
                   for a in report["answers"] for c in a["tool_call_log"])


@pytest.mark.parametrize(
    "arguments, message",
    [
        (("eval", "/nonexistent/dataset"), "dataset directory not found"),
        (("eval", str(FIXTURES), "--workers", "0"), "--workers"),
        (("ask", "Which event will happen next?", "--choice", "x"), "--world"),
        (("ask", "--world", "/nonexistent/world.json", "Which event will happen next?", "--choice", "x"), "world file not found"),
        (("build", "/nonexistent/video.mp4", "-o", "/tmp/x.json"), "not found"),
        (("build", str(FIXTURES / "annotations" / "annotation_00001.json"), "--camera", str(FIXTURES / "questions.json"), "-o", "/tmp/x.json"), "camera"),
    ],
)
def test_command_errors_are_one_line(arguments, message):
    completed = _run(*arguments, timeout=120)
    assert completed.returncode != 0
    assert message in completed.stderr
    assert "Traceback" not in completed.stderr


def test_ask_command_with_a_world_file_starts_its_own_server(tmp_path, six_document):
    world_path = tmp_path / "world.json"
    world_path.write_text(json.dumps(six_document))
    out = tmp_path / "answer.json"
    completed = _run("ask", "--world", str(world_path), "Which of the following will happen if the blue object is removed?",
                     "--choice", "The red object collides with the green object", "--choice", "The red object collides with the blue object",
                     "--json", str(out))
    assert completed.returncode == 0, completed.stderr
    document = json.loads(out.read_text())
    assert [c["verdict"] for c in document["choices"]] == ["correct", "wrong"]
    assert "simulate_edit" in completed.stdout and "CORRECT" in completed.stdout and "because:" in completed.stdout


def test_ask_command_against_a_running_server(tool_client, server_url, six_document):
    world = tool_client.create_world(six_document)
    completed = _run("ask", "--server", server_url, "--world-id", world.world_id, "Which event will happen next?",
                     "--choice", "The red object collides with the blue object")
    assert completed.returncode == 0, completed.stderr
    assert "WRONG" in completed.stdout  # the six-object world has no collision after the video


def test_build_command_fits_a_world_from_oracle_tracks(tmp_path):
    out = tmp_path / "world.json"
    annotation = FIXTURES / "annotations" / "annotation_00001.json"
    completed = _run("build", str(annotation), "--camera", str(FIXTURES / "ground_truth" / "scene_00001.json"), "-o", str(out))
    assert completed.returncode == 0, completed.stderr
    world = world_from_dict(json.loads(out.read_text()))
    properties = json.loads(annotation.read_text())["object_property"]
    assert {b.id for b in world.bodies} <= {p["object_id"] for p in properties}
    assert world.camera is not None and "bodies" in completed.stdout
    for body in world.bodies:
        prop = next(p for p in properties if p["object_id"] == body.id)
        assert (body.color, body.material, body.shape.kind) == (prop["color"], prop["material"], prop["shape"])
