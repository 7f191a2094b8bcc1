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
from schemas import read_schema
from synth.scene import (DENSITY_RANGE, OBJECT_HALF_SIZE, RESTITUTION_RANGE, SLIDING_FRICTION_RANGE,
                         SPHERE_SLIDING_FRICTION_RANGE, _shape_volume, inside_view)
from world.camera import project_with_depth
from world.types import Camera

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "tests" / "data" / "synth"
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
    jsonschema.validate(annotation, read_schema("clevrer_annotation.schema.json"))
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
    jsonschema.validate(entries, read_schema("clevrer_questions.schema.json"))


# --- An independent answer key --------------------------------------------------
# The generator computes its answers with planner.program on the programs. This
# re-derives them from the English text and the raw MuJoCo event list with a
# separate, small implementation of CLEVRER's semantics (docs/formats.md), so a
# bug in the program interpreter, the question writer or the annotation code
# shows up as a disagreement instead of being checked against itself.

COLORS = ("gray", "red", "blue", "green", "brown", "yellow", "cyan", "purple")
REFERENCE = re.compile(rf"[Tt]he (?:(?P<color>{'|'.join(COLORS)}) )?(?:(?P<material>metal|rubber) )?(?P<shape>sphere|cube|cylinder|object)")
KIND_ORDER = {"start": 0, "in": 1, "collision": 2, "out": 3, "end": 4}


def _object_named(phrase: str, objects: list[dict]) -> int:
    """The id of the one ground-truth object ``phrase`` ("the red rubber cube", "the cylinder") names."""
    match = REFERENCE.fullmatch(phrase.strip())
    assert match is not None, phrase
    color, material, shape = match["color"], match["material"], match["shape"]
    found = [o["object_id"] for o in objects
             if (color is None or o["color"] == color) and (material is None or o["material"] == material)
             and (shape == "object" or o["shape"] == shape)]
    assert len(found) == 1, f"{phrase!r} names {len(found)} objects"
    return found[0]


def _event_key(event: dict) -> tuple[str, frozenset[int]]:
    return event["kind"], frozenset(event["object_ids"])


def _ancestor_keys(target: dict, observed: list[dict]) -> set[tuple[str, frozenset[int]]]:
    """Causal ancestors of ``target``: recursively, the previous event in the trace of each object it involves."""
    ordered = sorted(observed, key=lambda e: (e["frame_id"], KIND_ORDER[e["kind"]], sorted(e["object_ids"])))
    found, frontier = [], [target]
    while frontier:
        current = frontier.pop()
        for oid in current["object_ids"]:
            trace = [e for e in ordered if oid in e["object_ids"]]
            k = next(i for i, e in enumerate(trace) if e is current)
            if k > 0 and all(trace[k - 1] is not f for f in found):
                found.append(trace[k - 1])
                frontier.append(trace[k - 1])
    return {_event_key(e) for e in found}


def _event_named(phrase: str, objects: list[dict]) -> tuple[str, frozenset[int]]:
    """An event phrase of a choice or question, as (kind, objects)."""
    for pattern, kind in ((r"(?:the collision between )?(.+?) and (.+)", "collision"),
                          (r"(.+?)'s colliding with (.+)", "collision"),
                          (r"(.+?) collides with (.+)", "collision"),
                          (r"(.+?)'s (?:entrance|entering the scene)", "in"),
                          (r"(.+?)'s (?:exit|exiting the scene)", "out")):
        match = re.fullmatch(pattern, phrase)
        if match is not None and (kind != "collision" or " and " in phrase or "collid" in phrase):
            return kind, frozenset(_object_named(g, objects) for g in match.groups())
    raise AssertionError(f"unknown event phrase {phrase!r}")


def independent_answer(question: str, choice: str, gt: dict) -> str:
    """'correct' or 'wrong', from the text and gt["events"] / gt["counterfactual"] only."""
    objects, observed_frames = gt["objects"], gt["observed_frames"]
    observed = [e for e in gt["events"] if e["frame_id"] < observed_frames]
    negated = " not " in question
    if question.startswith("Which event will happen next"):
        future = {_event_key(e) for e in gt["events"] if e["frame_id"] >= observed_frames}
        holds = _event_named(choice, objects) in future
    elif question.startswith("Which of the following will"):
        removed = _object_named(re.search(r"happen if (.+) is removed\?", question)[1], objects)
        replay = next(cf for cf in gt["counterfactual"] if cf["removed_object_id"] == removed)
        holds = _event_named(choice, objects) in {_event_key(e) for e in replay["events"] if e["frame_id"] < observed_frames}
    else:
        phrase = re.search(r"responsible for (.+)\?", question)[1]
        kind, ids = _event_named(phrase, objects)
        targets = [e for e in observed if _event_key(e) == (kind, ids)]
        assert len(targets) == 1, f"{question!r}: the target event happens {len(targets)} times"
        causes = _ancestor_keys(targets[0], observed)
        if choice.startswith("the presence of "):
            present = _object_named(choice.removeprefix("the presence of "), objects)
            holds = any(present in ids for _, ids in causes)
        else:
            holds = _event_named(choice, objects) in causes
    return "correct" if holds != negated else "wrong"


def test_independent_answer_key_reads_the_text():
    """The small implementation above, on a hand-made scene (so it can be trusted to disagree)."""
    gt = {"observed_frames": 10, "objects": [
        {"object_id": 0, "color": "red", "material": "metal", "shape": "cube"},
        {"object_id": 1, "color": "blue", "material": "rubber", "shape": "sphere"},
        {"object_id": 2, "color": "blue", "material": "metal", "shape": "sphere"}],
        "events": [{"kind": "collision", "object_ids": [0, 1], "frame_id": 3},
                   {"kind": "collision", "object_ids": [1, 2], "frame_id": 6},
                   {"kind": "collision", "object_ids": [0, 2], "frame_id": 12}],
        "counterfactual": [{"removed_object_id": 0, "events": [{"kind": "collision", "object_ids": [1, 2], "frame_id": 8}]}]}
    explain = "Which of the following is responsible for the collision between the rubber sphere and the metal sphere?"
    assert independent_answer(explain, "the presence of the cube", gt) == "correct"
    assert independent_answer(explain, "the collision between the cube and the rubber sphere", gt) == "correct"
    assert independent_answer(explain.replace("is responsible", "is not responsible"), "the presence of the cube", gt) == "wrong"
    assert independent_answer("Which event will happen next?", "The cube collides with the metal sphere", gt) == "correct"
    assert independent_answer("Which event will happen next?", "The cube collides with the rubber sphere", gt) == "wrong"
    removed = "Which of the following will happen if the red object is removed?"
    assert independent_answer(removed, "The rubber sphere collides with the metal sphere", gt) == "correct"
    with pytest.raises(AssertionError, match="names 2 objects"):
        independent_answer(removed, "The blue object collides with the cube", gt)


@pytest.mark.parametrize("index", INDICES)
def test_every_answer_agrees_with_an_independent_answer_key(index):
    gt = load("gt", index)
    asked = questions()[index]["questions"]
    assert asked, f"scene {index} has no questions"
    for question in asked:
        for choice in question["choices"]:
            assert independent_answer(question["question"], choice["choice"], gt) == choice["answer"], (question["question"], choice["choice"])


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


def test_camera_projects_onto_the_rendered_masks():
    """The true camera in ground_truth/ reproduces the render: centres of fully
    visible spheres project to their mask centroid within 1.5 px, in every scene
    that has an unoccluded sphere in the sampled frames (most of them)."""
    checked = {index: _sphere_centres_on_their_masks(index) for index in INDICES}
    assert sum(1 for n in checked.values() if n > 0) >= len(INDICES) // 2, checked


def _sphere_centres_on_their_masks(index: int) -> int:
    """Asserts the projection for each unoccluded sphere of every 20th frame; returns how many were checked."""
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
            pixel, _ = project_with_depth(camera, centre[None])
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
    return checked


def test_physical_parameters_follow_the_documented_ranges():
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
