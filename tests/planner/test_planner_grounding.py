"""Reference grounding: attribute phrases -> object ids; ambiguity and misses are reported, never guessed."""

from __future__ import annotations

import copy

import pytest

from planner.executor import VideoExecutor
from planner.grounding import (
    AttributeQuery,
    WorldObject,
    ground,
    ground_phrase,
    objects_from_summary,
    parse_object_phrase,
    program_references,
)
from planner.parser import parse_choice, parse_question

OBJECTS = (
    WorldObject(0, "red", "metal", "sphere"),
    WorldObject(1, "red", "rubber", "cube"),
    WorldObject(2, "green", "rubber", "cube"),
    WorldObject(3, None, "metal", "cylinder"),  # colour unknown (e.g. perception could not tell)
)


@pytest.mark.parametrize(
    "text, expected",
    [
        ("the rubber cube", AttributeQuery(material="rubber", shape="cube")),
        ("the green object", AttributeQuery(color="green")),
        ("The Grey metal Sphere", AttributeQuery(color="gray", material="metal", shape="sphere")),
        ("cylinder", AttributeQuery(shape="cylinder")),
        ("the thing", AttributeQuery()),
    ],
)
def test_parse_object_phrase(text, expected):
    assert parse_object_phrase(text) == expected


@pytest.mark.parametrize("text, message", [("the shiny cube", "unknown word 'shiny'"), ("the red blue cube", "two values for color"),
                                           ("the", "no attribute"), ("the cube #2", "cannot parse")])
def test_parse_object_phrase_rejects(text, message):
    with pytest.raises(ValueError, match=message):
        parse_object_phrase(text)


@pytest.mark.parametrize(
    "text, status, ids, uncertain",
    [
        ("the rubber cube", "ambiguous", (1, 2), ()),
        ("the red rubber cube", "unique", (1,), ()),
        ("the green object", "unique", (2,), (3,)),  # 3's colour is unknown: reported, not counted
        ("the sphere", "unique", (0,), ()),
        ("the red object", "ambiguous", (0, 1), (3,)),
        ("the yellow cube", "unmatched", (), ()),
        ("the metal cylinder", "unique", (3,), ()),
        ("the blue cylinder", "unmatched", (), (3,)),
    ],
)
def test_ground_phrase(text, status, ids, uncertain):
    grounding = ground_phrase(text, OBJECTS)
    assert (grounding.status, grounding.object_ids, grounding.uncertain) == (status, ids, uncertain)
    assert text in grounding.message()
    if status == "unique":
        assert grounding.object_id == ids[0]
    else:
        with pytest.raises(ValueError, match=status):
            grounding.object_id


def test_program_references_follow_the_parsed_programs():
    question = parse_question("Which of the following is responsible for the collision between the red rubber cube and the sphere?")
    assert program_references(question.program) == [AttributeQuery(color="red", material="rubber", shape="cube"), AttributeQuery(shape="sphere")]
    choice = parse_choice("the green object's entrance", "explanatory")
    assert program_references(choice) == [AttributeQuery(color="green")]
    assert program_references(parse_question("Which event will happen next?").program) == []
    assert [ground(q, OBJECTS).status for q in program_references(question.program)] == ["unique", "unique"]


def test_objects_from_summary_validates():
    assert objects_from_summary({"objects": [{"object_id": 4, "color": "red", "material": None, "shape": "cube"}]}) == (
        WorldObject(4, "red", None, "cube"),)
    with pytest.raises(ValueError, match="objects"):
        objects_from_summary({})
    with pytest.raises(ValueError, match=r"objects\[0\]\.object_id"):
        objects_from_summary({"objects": [{"color": "red"}]})


@pytest.fixture()
def two_reds(tool_client, six_document):
    """The six-object world with object 1 recoloured red: "the red object" names two objects."""
    document = copy.deepcopy(six_document)
    document["bodies"][1]["color"] = "red"
    return VideoExecutor(tool_client.create_world(document))


def test_ambiguous_question_reference_is_reported_over_http(two_reds):
    answer = two_reds.answer_text("Which of the following will happen if the red object is removed?",
                                  ["The green object collides with the yellow object"])
    assert answer.verdicts == [None]
    assert "ambiguous" in answer.error and "[0, 1]" in answer.error
    assert not any(c.tool == "simulate_edit" for c in two_reds.world.calls)  # nothing executed on a guess


def test_ambiguous_choice_reference_leaves_only_that_choice_undecided(two_reds):
    answer = two_reds.answer_text("Which of the following will happen if the green object is removed?",
                                  ["The red object collides with the yellow object", "The yellow object collides with the purple object",
                                   "The red metal object collides with the blue object"])
    assert answer.verdicts[0] is None and "ambiguous" in answer.choices[0].error
    assert answer.verdicts[1] in ("correct", "wrong")
    # "the blue object" no longer exists: unmatched, reported in the facts, and absent from every event.
    assert answer.verdicts[2] == "wrong" and "the blue object matches no object" in answer.choices[2].facts[0]


def test_unmatched_explained_event_is_reported(tool_client, six_document):
    executor = VideoExecutor(tool_client.create_world(six_document))
    answer = executor.answer_text("Which of the following is responsible for the cyan object's exit?", ["the presence of the red object"])
    assert answer.verdicts == [None]
    assert "cyan object matches no object" in answer.error


def test_an_object_missing_from_the_world_takes_part_in_no_event(tool_client, six_document):
    """A reference to an object the world lacks (never observed) is reported and answered as absent from every event."""
    executor = VideoExecutor(tool_client.create_world(six_document))
    answer = executor.answer_text("Which of the following will happen if the blue object is removed?",
                                  ["The cyan object collides with the red object", "The red object collides with the green object"])
    assert answer.verdicts == ["wrong", "correct"]
    assert "cyan object matches no object" in answer.choices[0].facts[0]
    removed_absent = executor.answer_text("Which of the following will happen if the cyan object is removed?",
                                          ["The red object collides with the blue object", "The red object collides with the green object"])
    # Removing an object the world does not contain changes nothing: the factual collisions answer.
    assert removed_absent.verdicts == ["correct", "wrong"]
    assert any("cyan object matches no object" in f for f in removed_absent.facts)
