"""Checks on the committed fixture set (tests/data/synth, made by `physmind synth`, see tests/data/README.md)."""

from __future__ import annotations

import json
import re
from functools import lru_cache
from pathlib import Path

import jsonschema
import numpy as np
import pytest

from planner.program import ProgramError, check_program, execute
from synth.annotate import program_scene_from_ground_truth
from synth.masks import decode_mask
from synth.questions import object_references
from synth.scene import OBJECT_HALF_SIZE, inside_view, project_points
from world.types import Camera

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "tests" / "data" / "synth"
SCHEMAS = ROOT / "schemas"
INDICES = sorted(int(p.stem.split("_")[1]) for p in (DATA / "ground_truth").glob("scene_*.json"))


@lru_cache(maxsize=None)
def load(kind: str, index: int) -> dict:
    name = {"annotation": f"annotations/annotation_{index:05d}.json", "gt": f"ground_truth/scene_{index:05d}.json", "masks": f"masks/proposal_{index:05d}.json"}[kind]
    return json.loads((DATA / name).read_text())


@lru_cache(maxsize=None)
def questions() -> dict[int, dict]:
    return {entry["scene_index"]: entry for entry in json.loads((DATA / "questions.json").read_text())}


def camera_of(gt: dict) -> Camera:
    c = gt["camera"]
    return Camera(c["width"], c["height"], c["fx"], c["fy"], c["cx"], c["cy"], tuple(c["position"]), tuple(tuple(r) for r in c["rotation"]))


def test_fixture_set_is_present():
    assert len(INDICES) >= 10
    for index in INDICES:
        assert (DATA / "videos" / f"video_{index:05d}.mp4").exists()
    assert sorted(questions()) == INDICES


@pytest.mark.parametrize("index", INDICES)
def test_annotation_validates_and_matches_ground_truth(index):
    annotation = load("annotation", index)
    jsonschema.validate(annotation, json.loads((SCHEMAS / "clevrer_annotation.schema.json").read_text()))
    gt = load("gt", index)
    assert len(annotation["motion_trajectory"]) == gt["observed_frames"] == 128
    # The annotation's collisions are exactly MuJoCo's observed collisions.
    observed = sorted((e["frame_id"], tuple(e["object_ids"])) for e in gt["events"] if e["kind"] == "collision" and e["observed"])
    assert sorted((c["frame_id"], tuple(c["object_ids"])) for c in annotation["collision"]) == observed
    # inside_camera_view agrees with projecting the object centre with the true camera.
    camera = camera_of(gt)
    for frame in annotation["motion_trajectory"][::16]:
        points = np.array([o["location"] for o in frame["objects"]])
        assert [o["inside_camera_view"] for o in frame["objects"]] == inside_view(camera, points).tolist()


def test_questions_validate_against_schema():
    entries = json.loads((DATA / "questions.json").read_text())
    jsonschema.validate(entries, json.loads((SCHEMAS / "clevrer_questions.schema.json").read_text()))


@pytest.mark.parametrize("index", INDICES)
def test_every_answer_re_derives_from_ground_truth_events(index):
    """Re-run every choice on the MuJoCo events of ground_truth/ with planner.program."""
    scene = program_scene_from_ground_truth(load("gt", index))
    asked = questions()[index]["questions"]
    assert asked, f"scene {index} has no questions"
    for question in asked:
        for choice in question["choices"]:
            result = execute(choice["program"] + question["program"], scene)
            assert result in ("yes", "no")
            assert ("correct" if result == "yes" else "wrong") == choice["answer"], (question["question"], choice["choice"])


def test_question_types_and_balance():
    all_questions = [q for entry in questions().values() for q in entry["questions"]]
    kinds = {q["question_type"] for q in all_questions}
    assert {"explanatory", "predictive", "counterfactual"} <= kinds
    answers = [c["answer"] for q in all_questions for c in q["choices"]]
    share = answers.count("correct") / len(answers)
    assert 0.35 <= share <= 0.65, share
    assert all(1 <= len(q["choices"]) <= 4 for q in all_questions)


# CLEVRER's templates (from the real questions in ../shared/clevrer and the task).
OBJ = r"the (?:(?:gray|red|blue|green|brown|yellow|cyan|purple) )?(?:(?:metal|rubber) )?(?:sphere|cube|cylinder|object)"
QUESTION_PATTERNS = [
    rf"Which of the following is (?:not )?responsible for the collision between {OBJ} and {OBJ}\?",
    rf"Which of the following is (?:not )?responsible for {OBJ}'s colliding with {OBJ}\?",
    rf"Which of the following is (?:not )?responsible for {OBJ}'s (?:exit|exiting the scene)\?",
    r"Which event will happen next\?",
    rf"Which of the following will (?:not )?happen if {OBJ} is removed\?",
]
CHOICE_PATTERNS = [
    rf"the presence of {OBJ}",
    rf"the collision between {OBJ} and {OBJ}",
    rf"{OBJ}'s colliding with {OBJ}",
    rf"{OBJ}'s (?:entrance|entering the scene)",
    rf"T{OBJ[1:]} collides with {OBJ}",
]


def _object_subprograms(program: list[str]) -> list[list[str]]:
    """The ``objects ... unique`` object references inside a program."""
    found, start = [], None
    for k, token in enumerate(program):
        if token == "objects":
            start = k
        elif token == "unique" and start is not None:
            found.append(program[start : k + 1])
            start = None
    return found


@pytest.mark.parametrize("index", INDICES)
def test_phrasing_and_shortest_unique_references(index):
    scene = program_scene_from_ground_truth(load("gt", index))
    minimal = {ref.program for refs in object_references(scene.objects).values() for ref in refs}
    for question in questions()[index]["questions"]:
        assert any(re.fullmatch(p, question["question"]) for p in QUESTION_PATTERNS), question["question"]
        programs = [question["program"]] + [c["program"] for c in question["choices"]]
        for choice in question["choices"]:
            assert any(re.fullmatch(p, choice["choice"]) for p in CHOICE_PATTERNS), choice["choice"]
            assert len(check_program(choice["program"])) == 1
        for program in programs:
            for sub in _object_subprograms(program):
                assert tuple(sub) in minimal, f"{sub} is not a shortest unique reference"
                execute(sub, scene)  # refers to exactly one object


@pytest.mark.parametrize("index", INDICES)
def test_counterfactual_differs_where_the_removed_object_collided(index):
    gt = load("gt", index)
    factual = {(e["kind"], tuple(e["object_ids"])) for e in gt["events"] if e["observed"]}
    final = {o["object_id"]: np.array(o["location"][gt["observed_frames"] - 1]) for o in gt["trajectory"]["objects"]}
    assert sorted(cf["removed_object_id"] for cf in gt["counterfactual"]) == sorted(o["object_id"] for o in gt["objects"])
    for cf in gt["counterfactual"]:
        removed = cf["removed_object_id"]
        assert all(removed not in e["object_ids"] for e in cf["events"])
        partners = {i for kind, ids in factual if kind == "collision" and removed in ids for i in ids if i != removed}
        if not partners:
            continue
        events = {(e["kind"], tuple(e["object_ids"])) for e in cf["events"] if e["observed"]}
        assert events != factual
        # Every object the removed one hit ends the video somewhere else.
        cf_final = {o["object_id"]: np.array(o["location"]) for o in cf["locations_at_video_end"]}
        for partner in partners:
            assert np.linalg.norm(cf_final[partner] - final[partner]) > 1e-3, (removed, partner)


def test_objects_enter_the_view_in_some_scenes():
    entering = 0
    for index in INDICES:
        annotation = load("annotation", index)
        gt = load("gt", index)
        for event in gt["events"]:
            if event["kind"] == "in" and event["observed"]:
                oid, frame = event["object_ids"][0], event["frame_id"]
                view = {f["frame_id"]: {o["object_id"]: o["inside_camera_view"] for o in f["objects"]} for f in annotation["motion_trajectory"]}
                assert not view[frame - 1][oid] and view[frame][oid]
                entering += int(not view[0][oid])  # came in from outside, not a re-entry
    assert entering >= 3


@pytest.mark.parametrize("index", INDICES[:4])
def test_camera_projects_onto_the_rendered_masks(index):
    """The true camera in ground_truth/ reproduces the render: centres of fully
    visible spheres project to their mask centroid within 1.5 px."""
    gt = load("gt", index)
    camera = camera_of(gt)
    masks = load("masks", index)
    spheres = {o["object_id"] for o in gt["objects"] if o["shape"] == "sphere"}
    checked = 0
    for frame in masks["frames"][::20]:
        for obj in frame["objects"]:
            if obj["object_id"] not in spheres:
                continue
            track = next(o for o in gt["trajectory"]["objects"] if o["object_id"] == obj["object_id"])
            centre = np.array(track["location"][frame["frame_index"]])
            pixel, _ = project_points(camera, centre[None])
            x, y, w, h = obj["bbox"]
            if x <= 1 or y <= 1 or x + w >= camera.width - 1 or y + h >= camera.height - 1:
                continue
            others = [o for o in frame["objects"] if o["object_id"] != obj["object_id"]]
            mask = decode_mask(obj["mask"])
            # Skip spheres partly hidden behind another object.
            if any(decode_mask(o["mask"])[max(y - 3, 0) : y + h + 3, max(x - 3, 0) : x + w + 3].any() for o in others):
                continue
            ys, xs = np.nonzero(mask)
            assert abs(xs.mean() - pixel[0, 0]) < 1.5 and abs(ys.mean() - pixel[0, 1]) < 1.5
            checked += 1
    if checked == 0:
        pytest.skip(f"scene {index}: no unoccluded sphere in the sampled frames")


def test_physical_parameters_follow_the_documented_ranges():
    from synth.scene import DENSITY_RANGE, RESTITUTION_RANGE, SLIDING_FRICTION_RANGE, SPHERE_SLIDING_FRICTION_RANGE, _shape_volume

    for index in INDICES:
        for obj in load("gt", index)["objects"]:
            density = obj["mass"] / _shape_volume(obj["shape"], OBJECT_HALF_SIZE)
            low, high = DENSITY_RANGE[obj["material"]]
            assert low - 1 <= density <= high + 1
            low, high = (SPHERE_SLIDING_FRICTION_RANGE if obj["shape"] == "sphere" else SLIDING_FRICTION_RANGE)[obj["material"]]
            assert low - 1e-5 <= obj["friction"] <= high + 1e-5
            assert RESTITUTION_RANGE[obj["material"]][0] - 1e-5 <= obj["restitution"] <= RESTITUTION_RANGE[obj["material"]][1] + 1e-5
    # metal is heavier than rubber for every shape
    assert max(DENSITY_RANGE["rubber"]) < min(DENSITY_RANGE["metal"])


def test_programs_fail_loudly_on_a_wrong_scene():
    """A program naming an object that does not exist must raise, not answer."""
    scene = program_scene_from_ground_truth(load("gt", INDICES[0]))
    missing = next(c for c in ("gray", "red", "blue", "green", "brown", "yellow", "cyan", "purple") if all(o.color != c for o in scene.objects))
    with pytest.raises(ProgramError):
        execute(["objects", missing, "filter_color", "unique"], scene)
