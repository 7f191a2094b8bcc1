"""The CLEVRER program interpreter: operators on hand-made scenes, laws, and the real programs.

The hand-made scene (observed window 128 frames):

    objects: 0 red metal sphere, 1 blue rubber cube, 2 green rubber cylinder, 3 red rubber cube
    events:  in(2)@10  c(0,1)@20  c(1,2)@40  out(1)@60  c(0,3)@70 | future: c(2,3)@140  out(0)@150
    traces:  0: c01 c03 | 1: c01 c12 out1 | 2: in2 c12 | 3: c03
    ancestors: c12 <- {c01, in2}; out1 <- {c12, c01, in2}; c03 <- {c01}; c01 <- {}
    counterfactual (removed -> events): 0 -> c(1,2)@50, c(2,3)@130 (after the window)
                                        1 -> c(0,3)@70, c(0,2)@90
                                        2 -> c(0,1)@20, c(0,3)@70
                                        3 -> c(0,1)@20, c(1,2)@40
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from planner.program import (
    EventRecord,
    MotionOracle,
    ObjectRecord,
    ProgramError,
    ProgramScene,
    answer_question,
    causal_ancestors,
    check_program,
    execute,
    reference_spans,
    score_choice,
)

# Vendored real CLEVRER questions (tests/data/README.md): always present, so the test never skips.
SHARED_QUESTIONS = Path(__file__).resolve().parents[1] / "data" / "clevrer" / "clevrer_explanatory_train_subset.json"

OBJECTS = (
    ObjectRecord(0, "red", "metal", "sphere"),
    ObjectRecord(1, "blue", "rubber", "cube"),
    ObjectRecord(2, "green", "rubber", "cylinder"),
    ObjectRecord(3, "red", "rubber", "cube"),
)
C = lambda a, b, f: EventRecord("collision", (a, b), f)  # noqa: E731
EVENTS = (
    EventRecord("in", (2,), 10),
    C(0, 1, 20),
    C(1, 2, 40),
    EventRecord("out", (1,), 60),
    C(0, 3, 70),
    C(2, 3, 140),
    EventRecord("out", (0,), 150),
)
COUNTERFACTUAL = {
    0: (C(1, 2, 50), C(2, 3, 130)),
    1: (C(0, 3, 70), C(0, 2, 90)),
    2: (C(0, 1, 20), C(0, 3, 70)),
    3: (C(0, 1, 20), C(1, 2, 40)),
}


class Motion(MotionOracle):
    """Objects 0 and 1 move before frame 60, object 2 always, object 3 never; all visible."""

    def is_visible(self, object_id, frame):
        return True

    def is_moving(self, object_id, frame):
        if frame is None:
            return object_id != 3
        return object_id == 2 or (object_id in (0, 1) and frame < 60)

    def direction(self, object_id, frame):
        return "left"


def make_scene(**overrides) -> ProgramScene:
    fields = dict(objects=OBJECTS, events=EVENTS, observed_frames=128, counterfactual=lambda i: COUNTERFACTUAL[i], motion=Motion())
    fields.update(overrides)
    return ProgramScene(**fields)


RED_SPHERE = ["objects", "red", "filter_color", "sphere", "filter_shape", "unique"]
BLUE = ["objects", "blue", "filter_color", "unique"]
GREEN = ["objects", "green", "filter_color", "unique"]
RED_CUBE = ["objects", "red", "filter_color", "cube", "filter_shape", "unique"]
RUBBER_CUBE_RED = ["objects", "red", "filter_color", "rubber", "filter_material", "unique"]


def collision(a, b, source="events"):
    return [source, *a, "filter_collision", *b, "filter_collision", "unique"]


@pytest.mark.parametrize(
    "program, expected",
    [
        (["objects", "count"], 4),
        (["objects", "red", "filter_color", "count"], 2),
        (["objects", "rubber", "filter_material", "cube", "filter_shape", "count"], 2),
        (["events", "objects", "filter_collision", "count"], 3),  # observed collisions only
        (["events", "count"], 7),  # 5 observed events + start + end markers
        (["unseen_events", "count"], 2),
        (["all_events", "count"], 6),
        (["events", *BLUE, "filter_collision", "first", "filter_order", "query_frame"], 20),
        (["events", *BLUE, "filter_collision", "last", "filter_order", *BLUE, "query_collision_partner", "query_shape"], "cylinder"),
        (["events", *BLUE, "filter_collision", "second", "filter_order", "query_frame"], 40),
        (["events", *GREEN, "filter_in", "unique", "query_object", "query_material"], "rubber"),
        (["events", "events", *BLUE, "filter_out", "unique", "filter_before", "count"], 4),  # start, in2, c01, c12
        (["events", "events", *BLUE, "filter_out", "unique", "filter_after", "count"], 2),  # c03, end
        (["events", "filter_end", "query_frame"], 127),
        (["events", "filter_start", "query_frame"], 0),
        (["events", *RUBBER_CUBE_RED, "filter_out", "exist"], "no"),
        (["events", *BLUE, "filter_out", "exist"], "yes"),
        (["events", *RED_SPHERE, "filter_out", "exist"], "no"),  # its exit is after the video
        (["unseen_events", *RED_SPHERE, "filter_out", "exist"], "yes"),
        (["events", "objects", "filter_collision", *GREEN, "filter_counterfact", "count"], 2),  # c01, c03 survive
        (["events", "objects", "filter_collision", *RED_SPHERE, "filter_counterfact", "count"], 1),  # only c12
        ([*RED_SPHERE, "counterfact_events", "count"], 1),  # c23@130 is after the window
        (["objects", "events", "filter_end", "query_frame", "filter_moving", "count"], 1),  # only the cylinder at the end
        (["objects", "null", "filter_stationary", "count"], 1),
        (["objects", "30", "filter_moving", "count"], 3),
        (["objects", "30", "filter_resting", "unique", "query_shape"], "cube"),
        ([*GREEN, "5", "query_direction"], "left"),
        (["objects", "events", *RED_CUBE, "filter_collision", "unique", "query_frame", "filter_moving", "count"], 1),
        (["objects", "exist", "negate"], "no"),
    ],
)
def test_operators(program, expected):
    assert execute(program, make_scene()) == expected


@pytest.mark.parametrize(
    "event, expected",
    [
        (C(0, 1, 20), set()),
        (C(1, 2, 40), {C(0, 1, 20), EventRecord("in", (2,), 10)}),
        (EventRecord("out", (1,), 60), {C(1, 2, 40), C(0, 1, 20), EventRecord("in", (2,), 10)}),
        (C(0, 3, 70), {C(0, 1, 20)}),
        (EventRecord("in", (2,), 10), set()),
    ],
)
def test_causal_ancestors(event, expected):
    assert causal_ancestors(make_scene(), event) == expected


EXPLAIN_C12 = ["events", *collision(BLUE, GREEN), "filter_ancestor", "belong_to"]
EXPLAIN_OUT1 = ["events", "events", *BLUE, "filter_out", "unique", "filter_ancestor", "belong_to"]
EXPLAIN_C03 = ["events", *collision(RED_SPHERE, RED_CUBE), "filter_ancestor", "belong_to"]


@pytest.mark.parametrize(
    "question, choice, correct",
    [
        (EXPLAIN_C12, RED_SPHERE, True),  # takes part in c01, an ancestor
        (EXPLAIN_C12, RED_CUBE, False),  # its only collision is later
        (EXPLAIN_C12, ["events", *GREEN, "filter_in", "unique"], True),
        (EXPLAIN_C12, collision(RED_SPHERE, BLUE), True),
        (EXPLAIN_C12 + ["negate"], RED_CUBE, True),
        (EXPLAIN_C12 + ["negate"], RED_SPHERE, False),
        (EXPLAIN_OUT1, collision(BLUE, GREEN), True),
        (EXPLAIN_OUT1, ["events", *GREEN, "filter_in", "unique"], True),
        (EXPLAIN_OUT1, RED_CUBE, False),
        (EXPLAIN_C03, BLUE, True),
        (EXPLAIN_C03, GREEN, False),
        (EXPLAIN_C03, ["events", *GREEN, "filter_in", "unique"], False),
        # predictive
        (["unseen_events", "belong_to"], collision(GREEN, RED_CUBE, "all_events"), True),
        (["unseen_events", "belong_to"], collision(RED_SPHERE, BLUE, "all_events"), False),  # observed, not future
        (["unseen_events", "belong_to"], collision(RED_CUBE, GREEN, "all_events"), True),  # order of the pair is irrelevant
        # counterfactual
        ([*RED_SPHERE, "counterfact_events", "belong_to"], collision(BLUE, GREEN, "all_events"), True),
        ([*RED_SPHERE, "counterfact_events", "belong_to"], collision(GREEN, RED_CUBE, "all_events"), False),  # frame 130
        ([*RED_SPHERE, "counterfact_events", "belong_to", "negate"], collision(BLUE, RED_CUBE, "all_events"), True),
        ([*BLUE, "counterfact_events", "belong_to"], collision(RED_SPHERE, GREEN, "all_events"), True),
        ([*GREEN, "counterfact_events", "belong_to", "negate"], collision(RED_SPHERE, BLUE, "all_events"), False),
    ],
)
def test_choice_scoring(question, choice, correct):
    assert score_choice(question, choice, make_scene()) is correct


def test_answer_question_labels_every_choice():
    question = {"program": EXPLAIN_C12, "choices": [{"program": RED_SPHERE}, {"program": RED_CUBE}]}
    assert answer_question(question, make_scene()) == ["correct", "wrong"]


@pytest.mark.parametrize(
    "program, scene_overrides, message",
    [
        (["objects", "red", "filter_color", "unique"], {}, "exactly one"),
        (["objects", "pink", "filter_color"], {}, "unknown token"),
        (["objects", "objects"], {}, "leaves 2 values"),
        (["filter_color"], {}, "needs 2 argument"),
        (["objects", "events", "filter_collision"], {}, "argument 1 must be events"),
        ([*RED_SPHERE, "counterfact_events"], {"counterfactual": None}, "no counterfactual"),
        (["objects", "null", "filter_moving"], {"motion": None}, "no motion"),
        (["events", "objects", "filter_collision", "third", "filter_order"], {}, "unknown token"),
        ([*RED_SPHERE, *RED_SPHERE, "query_collision_partner"], {}, "argument 1 must be event"),
        (["all_events", "objects", "filter_collision", "first", "filter_order", "query_frame"], {}, "no frame"),
    ],
)
def test_errors_name_the_problem(program, scene_overrides, message):
    with pytest.raises(ProgramError, match=message):
        execute(program, make_scene(**scene_overrides))


def test_malformed_records_are_rejected():
    with pytest.raises(ValueError, match="color"):
        ObjectRecord(0, "pink", "metal", "cube")
    with pytest.raises(ValueError, match="involves 2"):
        EventRecord("collision", (1,), 3)
    assert EventRecord("collision", (3, 1), 5).objects == (1, 3)


# --- laws on random scenes -------------------------------------------------------


@st.composite
def random_scenes(draw):
    count = draw(st.integers(3, 5))
    objects = tuple(ObjectRecord(i, ("red", "blue", "green", "cyan", "gray")[i], "rubber", "cube") for i in range(count))
    events = []
    for frame in sorted(draw(st.lists(st.integers(0, 200), min_size=1, max_size=8, unique=True))):
        a, b = draw(st.tuples(st.integers(0, count - 1), st.integers(0, count - 1)).filter(lambda p: p[0] != p[1]))
        events.append(C(a, b, frame))
    return ProgramScene(objects=objects, events=tuple(events), observed_frames=128)


@settings(max_examples=60, deadline=None)
@given(random_scenes())
def test_ancestors_precede_and_negation_complements(scene):
    observed = [e for e in scene.events if e.frame < 128]
    for event in observed:
        ancestors = causal_ancestors(scene, event)
        assert all(a.frame < event.frame for a in ancestors)
        assert event not in ancestors
        objs = {o for a in ancestors for o in a.objects}
        program = ["events", "events", "objects", str(scene.objects[event.objects[0]].color), "filter_color", "unique", "filter_collision",
                   "objects", str(scene.objects[event.objects[1]].color), "filter_color", "unique", "filter_collision", "unique",
                   "filter_ancestor", "belong_to"]
        pair_count = sum(1 for e in observed if e.objects == event.objects)
        for obj in scene.objects:
            choice = ["objects", obj.color, "filter_color", "unique"]
            if pair_count != 1:
                with pytest.raises(ProgramError):
                    score_choice(program, choice, scene)
                continue
            responsible = score_choice(program, choice, scene)
            assert responsible == (obj.id in objs)
            assert score_choice(program + ["negate"], choice, scene) is not responsible


# --- the real CLEVRER programs ----------------------------------------------------


def _shared_questions():
    data = json.loads(SHARED_QUESTIONS.read_text())
    return [(key, q) for key, entry in sorted(data.items()) for q in entry["questions"]]


def test_every_official_program_type_checks():
    questions = _shared_questions()
    assert len(questions) == 564
    for key, question in questions:
        for choice in question["choices"]:
            value = check_program(choice["program"])
            assert len(value) == 1 and value[0] in ("object", "event"), (key, choice["program"])
            assert check_program(question["program"], value) == ("bool",), (key, question["program"])
            assert check_program(choice["program"] + question["program"]) == ("bool",)


@pytest.mark.parametrize(
    "program, inputs, expected",
    [
        (["objects", "red", "filter_color", "unique"], (), ("object",)),
        (["events", "objects", "filter_collision"], (), ("events",)),
        (["unseen_events", "belong_to"], ("event",), ("bool",)),
        (["objects", "events", "filter_end", "query_frame", "filter_moving", "count"], (), ("int",)),
    ],
)
def test_check_program_types(program, inputs, expected):
    assert check_program(program, inputs) == expected


@pytest.mark.parametrize(
    "program, inputs",
    [
        (["objects", "unique", "belong_to"], ()),  # missing the event list
        (["events", "red", "filter_color"], ()),
        (["unseen_events", "belong_to"], ("bool",)),
        (["objects", "sphere", "filter_color"], ()),  # shape given to a colour filter
    ],
)
def test_check_program_rejects(program, inputs):
    with pytest.raises(ProgramError):
        check_program(program, inputs)


def test_bound_references_stand_for_the_grounded_objects():
    """execute(bound=...): each object reference pushes the object grounding chose, even where the filters would
    find several objects or none; the rest of the program runs as usual."""
    objects = (ObjectRecord(1, "red", "metal", "cube"), ObjectRecord(2, "red", "rubber", "cube"), ObjectRecord(3, "blue", "rubber", "sphere"))
    scene = ProgramScene(objects=objects, events=(EventRecord("collision", (2, 3), 40),), observed_frames=128)
    program = ["events", "objects", "red", "filter_color", "unique", "filter_collision",
               "objects", "green", "filter_color", "unique", "filter_collision", "exist"]
    assert reference_spans(program) == [(1, 4), (6, 9)]
    with pytest.raises(ProgramError, match="unique"):
        execute(program, scene)
    assert execute(program, scene, bound=[2, 3]) == "yes"
    assert execute(program, scene, bound=[1, 3]) == "no"
    with pytest.raises(ProgramError, match="2 object reference"):
        execute(program, scene, bound=[2])
    with pytest.raises(ProgramError, match="unknown object id 9"):
        execute(program, scene, bound=[2, 9])
