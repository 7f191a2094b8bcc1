"""Question generation units: shortest unique references and balanced options."""

from __future__ import annotations

import numpy as np
import pytest

from planner.program import EventRecord, ObjectRecord, ProgramScene, execute
from synth.questions import CLEVRER_REFERENCE_WEIGHTS, _choose_balanced, object_references, scene_questions

O = ObjectRecord


@pytest.mark.parametrize(
    "objects, target, phrases",
    [
        # a unique shape is enough
        ((O(0, "red", "metal", "sphere"), O(1, "red", "metal", "cube"), O(2, "blue", "rubber", "cube")), 0, {"sphere"}),
        # colour or material alone both single out object 2: both are shortest
        ((O(0, "red", "metal", "sphere"), O(1, "red", "metal", "cube"), O(2, "blue", "rubber", "cube")), 2, {"blue object", "rubber object"}),
        # two attributes needed
        ((O(0, "red", "metal", "cube"), O(1, "red", "rubber", "cube"), O(2, "blue", "metal", "cube"), O(3, "red", "metal", "sphere")), 0, {"red metal cube"}),
        ((O(0, "red", "metal", "cube"), O(1, "red", "rubber", "cube"), O(2, "blue", "metal", "sphere")), 1, {"rubber object"}),
    ],
)
def test_shortest_unique_references(objects, target, phrases):
    references = object_references(objects)[target]
    assert {r.phrase for r in references} == phrases
    scene = ProgramScene(objects=objects, events=())
    for reference in references:
        assert execute(list(reference.program), scene) == objects[target]


@pytest.mark.parametrize("n_correct, n_wrong, total", [(5, 5, 4), (1, 6, 4), (6, 1, 4), (0, 3, 2), (2, 0, 2), (1, 1, 4)])
def test_balanced_choice_respects_pools(n_correct, n_wrong, total):
    rng = np.random.default_rng(0)
    for _ in range(20):
        picked = _choose_balanced(rng, list(range(n_correct)), list(range(100, 100 + n_wrong)), total)
        assert len(picked) == min(total, n_correct + n_wrong)
        assert all((value < 100) == is_correct for value, is_correct in picked)
        assert len({v for v, _ in picked}) == len(picked)


def test_generated_answers_match_the_interpreter_and_types_appear():
    objects = (O(0, "red", "metal", "sphere"), O(1, "blue", "rubber", "cube"), O(2, "green", "rubber", "cylinder"), O(3, "yellow", "metal", "cube"))
    C = lambda a, b, f: EventRecord("collision", (a, b), f)  # noqa: E731
    events = (EventRecord("in", (2,), 10), C(0, 1, 20), C(1, 2, 40), C(0, 3, 70), C(2, 3, 140))
    counterfactual = {0: (C(1, 2, 50),), 1: (C(0, 3, 70), C(0, 2, 90)), 2: (C(0, 1, 20), C(0, 3, 70)), 3: (C(0, 1, 20), C(1, 2, 40))}
    scene = ProgramScene(objects=objects, events=events, observed_frames=128, counterfactual=lambda i: counterfactual[i])
    questions = scene_questions(scene, np.random.default_rng(1))
    assert {q["question_type"] for q in questions} == {"explanatory", "predictive", "counterfactual"}
    assert [q["question_id"] for q in questions] == list(range(len(questions)))
    for q in questions:
        for choice in q["choices"]:
            expected = execute(choice["program"] + q["program"], scene)
            assert choice["answer"] == ("correct" if expected == "yes" else "wrong")


def _references(question: dict) -> list[tuple[str, ...]]:
    """Every ``objects ... unique`` run of a question and its options."""
    found = []
    for program in [question["program"]] + [c["program"] for c in question["choices"]]:
        start = None
        for k, token in enumerate(program):
            if token == "objects":
                start = k
            elif token == "unique" and start is not None:
                found.append(tuple(program[start : k + 1]))
                start = None
    return found


def _named_objects(question: dict, scene: ProgramScene) -> set[int]:
    """Ids of every object a question or its options name (each ``objects ... unique`` run on the scene)."""
    return {execute(list(reference), scene).id for reference in _references(question)}


def test_objects_never_seen_in_the_video_are_never_named():
    """Object 4 is launched late and only shows up after the video; it collides with
    1 after the video and its absence changes nothing observed."""
    objects = (O(0, "red", "metal", "sphere"), O(1, "blue", "rubber", "cube"), O(2, "green", "rubber", "cylinder"), O(3, "yellow", "metal", "cube"), O(4, "purple", "metal", "sphere"))
    C = lambda a, b, f: EventRecord("collision", (a, b), f)  # noqa: E731
    events = (C(0, 1, 20), C(1, 2, 40), C(0, 3, 70), C(2, 3, 135), C(1, 4, 140), C(0, 4, 150))
    counterfactual = {0: (C(1, 2, 50),), 1: (C(0, 3, 70), C(0, 2, 90)), 2: (C(0, 1, 20), C(0, 3, 70)), 3: (C(0, 1, 20), C(1, 2, 40)), 4: (C(0, 1, 20), C(1, 2, 40), C(0, 3, 70))}
    scene = ProgramScene(objects=objects, events=events, observed_frames=128, counterfactual=lambda i: counterfactual[i])
    unfiltered, filtered = set(), set()
    kinds = set()
    for seed in range(20):
        for question in scene_questions(scene, np.random.default_rng(seed)):
            unfiltered |= _named_objects(question, scene)
        for question in scene_questions(scene, np.random.default_rng(seed), seen=frozenset({0, 1, 2, 3})):
            filtered |= _named_objects(question, scene)
            kinds.add(question["question_type"])
            for choice in question["choices"]:  # answers still come from the interpreter on the full scene
                assert choice["answer"] == ("correct" if execute(choice["program"] + question["program"], scene) == "yes" else "wrong")
    assert 4 in unfiltered  # without the rule the late object is asked about
    assert 4 not in filtered and filtered == {0, 1, 2, 3}
    assert kinds == {"explanatory", "predictive", "counterfactual"}


def test_clevrer_phrasing_names_objects_in_several_unique_ways():
    """CLEVRER's phrasing: every reference still names exactly one object, the answers still come from the
    interpreter, and objects are also named by more than their shortest attributes (as CLEVRER's questions
    do), in kinds drawn with CLEVRER's weights (colour + shape the commonest); the shortest phrasing never does."""
    objects = (O(0, "red", "metal", "sphere"), O(1, "blue", "rubber", "cube"), O(2, "green", "rubber", "cylinder"), O(3, "yellow", "metal", "cube"))
    C = lambda a, b, f: EventRecord("collision", (a, b), f)  # noqa: E731
    events = (EventRecord("in", (2,), 10), C(0, 1, 20), C(1, 2, 40), C(0, 3, 70), C(2, 3, 140))
    counterfactual = {0: (C(1, 2, 50),), 1: (C(0, 3, 70), C(0, 2, 90)), 2: (C(0, 1, 20), C(0, 3, 70)), 3: (C(0, 1, 20), C(1, 2, 40))}
    scene = ProgramScene(objects=objects, events=events, observed_frames=128, counterfactual=lambda i: counterfactual[i])
    shortest = {r.program for refs in object_references(objects).values() for r in refs}
    kinds: dict[tuple[str, ...], int] = {}
    two_ways = 0
    for seed in range(30):
        for question in scene_questions(scene, np.random.default_rng(seed), phrasing="clevrer"):
            for choice in question["choices"]:
                assert choice["answer"] == ("correct" if execute(choice["program"] + question["program"], scene) == "yes" else "wrong")
            named: dict[int, set] = {}
            for reference in _references(question):
                named.setdefault(execute(list(reference), scene).id, set()).add(reference)
                kind = tuple(token.removeprefix("filter_") for token in reference if token.startswith("filter_"))
                kinds[kind] = kinds.get(kind, 0) + 1
            two_ways += any(len(v) > 1 for v in named.values())
        for question in scene_questions(scene, np.random.default_rng(seed)):
            assert set(_references(question)) <= shortest
    assert max(kinds, key=kinds.get) == ("color", "shape") and ("color", "material", "shape") in kinds
    assert two_ways > 0  # some question names one object in two ways
    with pytest.raises(ValueError, match="phrasing"):
        scene_questions(scene, np.random.default_rng(0), phrasing="poetic")


def test_clevrer_weights_are_the_counts_of_the_real_questions():
    """CLEVRER_REFERENCE_WEIGHTS are the attribute-combination counts of every object reference in the
    programs of the vendored real CLEVRER questions (tests/data/clevrer)."""
    import json
    from pathlib import Path

    path = Path(__file__).resolve().parents[1] / "data" / "clevrer" / "clevrer_explanatory_train_subset.json"
    counts: dict[tuple[str, ...], int] = {}
    for video in json.loads(path.read_text()).values():
        for question in video["questions"]:
            for reference in _references({"program": question["program"], "choices": question["choices"]}):
                kind = tuple(token.removeprefix("filter_") for token in reference if token.startswith("filter_"))
                counts[kind] = counts.get(kind, 0) + 1
    assert counts == CLEVRER_REFERENCE_WEIGHTS


def test_seen_object_ids_counts_observed_frames_in_view():
    from synth.annotate import seen_object_ids

    views = {0: [True] * 10, 1: [False] * 7 + [True] * 3, 2: [False] * 5 + [True] * 5, 3: [False] * 10 + [True] * 5}
    gt = {"observed_frames": 10, "trajectory": {"objects": [{"object_id": k, "inside_camera_view": v} for k, v in views.items()]}}
    assert seen_object_ids(gt) == {0, 2}  # 1: 3 frames only; 3: in view only after the video
