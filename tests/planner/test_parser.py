"""Tests for planner.parser / planner.grammar and `physmind parse`."""

from __future__ import annotations

import json
from collections import Counter
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from physmind.cli import main
from planner.grammar import EventRef, ObjectRef, ParseError, parse_choice_ast, tokenize
from planner.parser import (
    normalize_program,
    parse_choice,
    parse_question,
    parse_question_file,
)
from planner.program import EventRecord, ObjectRecord, ProgramScene, execute
from planner.vocabulary import COLORS, MATERIALS, SHAPES
from synth.questions import scene_questions
from world.types import COLORS as WORLD_COLORS
from world.types import MATERIALS as WORLD_MATERIALS
from world.types import SHAPE_KINDS

# Vendored real CLEVRER questions (tests/data/README.md): always present, so the test never skips.
SHARED_QUESTIONS = Path(__file__).resolve().parents[1] / "data" / "clevrer" / "clevrer_explanatory_train_subset.json"


def words(program: str) -> tuple[str, ...]:
    return tuple(program.split())


# Real CLEVRER sentences with their official programs, copied from the shared file.
REAL_QUESTIONS = [
    (
        "Which of the following is responsible for the brown cube's colliding with the blue object?",
        "events events objects brown filter_color cube filter_shape unique filter_collision objects blue "
        "filter_color unique filter_collision unique filter_ancestor belong_to",
    ),
    (
        "Which of the following is not responsible for the yellow sphere's exit?",
        "events events objects yellow filter_color sphere filter_shape unique filter_out unique "
        "filter_ancestor belong_to negate",
    ),
    (
        "Which of the following is not responsible for the collision between the cylinder and the blue cube?",
        "events events objects cylinder filter_shape unique filter_collision objects blue filter_color cube "
        "filter_shape unique filter_collision unique filter_ancestor belong_to negate",
    ),
    (
        "Which of the following is not responsible for the green metal object's exiting the scene?",
        "events events objects green filter_color metal filter_material unique filter_out unique "
        "filter_ancestor belong_to negate",
    ),
    (
        "Which of the following is responsible for the sphere's colliding with the rubber cube?",
        "events events objects sphere filter_shape unique filter_collision objects rubber filter_material "
        "cube filter_shape unique filter_collision unique filter_ancestor belong_to",
    ),
]

REAL_EXPLANATORY_CHOICES = [
    (
        "the presence of the green metal cube",
        "objects green filter_color metal filter_material cube filter_shape unique",
    ),
    ("the presence of the sphere", "objects sphere filter_shape unique"),
    ("the presence of the rubber object", "objects rubber filter_material unique"),
    (
        "the collision between the green cube and the brown object",
        "events objects green filter_color cube filter_shape unique filter_collision objects brown "
        "filter_color unique filter_collision unique",
    ),
    (
        "the green cube's entering the scene",
        "events objects green filter_color cube filter_shape unique filter_in unique",
    ),
    ("the blue object's entrance", "events objects blue filter_color unique filter_in unique"),
    (
        "the blue metal cylinder's colliding with the cyan rubber object",
        "events objects blue filter_color metal filter_material cylinder filter_shape unique filter_collision "
        "objects cyan filter_color rubber filter_material unique filter_collision unique",
    ),
]


@pytest.mark.parametrize(("text", "official"), REAL_QUESTIONS)
def test_real_questions_parse_to_official_program(text: str, official: str) -> None:
    parsed = parse_question(text)
    assert parsed.question_type == "explanatory"
    assert parsed.program == words(official)


@pytest.mark.parametrize(("text", "official"), REAL_EXPLANATORY_CHOICES)
def test_real_explanatory_choices_parse_to_official_program(text: str, official: str) -> None:
    assert parse_choice(text, "explanatory") == words(official)


CUBE = "objects cube filter_shape unique"
RED_SPHERE = "objects red filter_color sphere filter_shape unique"
CYAN_CYLINDER = "objects cyan filter_color cylinder filter_shape unique"

FUTURE_QUESTIONS = [
    ("Which event will happen next?", "predictive", "unseen_events belong_to"),
    ("What will happen next?", "predictive", "unseen_events belong_to"),
    (
        "What will happen without the cyan cylinder?",
        "counterfactual",
        f"{CYAN_CYLINDER} counterfact_events belong_to",
    ),
    (
        "Which of the following will not happen if the cylinder is removed?",
        "counterfactual",
        "objects cylinder filter_shape unique counterfact_events belong_to negate",
    ),
    (
        "Which of the following will happen if the red sphere is removed?",
        "counterfactual",
        f"{RED_SPHERE} counterfact_events belong_to",
    ),
    (
        "Without the red sphere, which event will not happen?",
        "counterfactual",
        f"{RED_SPHERE} counterfact_events belong_to negate",
    ),
    (
        "If the cyan cylinder were removed, what will happen?",
        "counterfactual",
        f"{CYAN_CYLINDER} counterfact_events belong_to",
    ),
]


@pytest.mark.parametrize(("text", "question_type", "program"), FUTURE_QUESTIONS)
def test_predictive_and_counterfactual_questions(text: str, question_type: str, program: str) -> None:
    parsed = parse_question(text)
    assert parsed.question_type == question_type
    assert parsed.program == words(program)


RED_SPHERE_CUBE = f"all_events {RED_SPHERE} filter_collision {CUBE} filter_collision unique"
CUBE_RED_SPHERE = f"all_events {CUBE} filter_collision {RED_SPHERE} filter_collision unique"


@pytest.mark.parametrize("question_type", ["predictive", "counterfactual"])
@pytest.mark.parametrize(
    ("text", "program"),
    [
        ("The red sphere collides with the cube", RED_SPHERE_CUBE),
        ("The cube and the red sphere collide", CUBE_RED_SPHERE),
        ("The cube will collide with the red sphere.", CUBE_RED_SPHERE),
        ("the collision between the red sphere and the cube", RED_SPHERE_CUBE),
    ],
)
def test_future_choices_name_a_candidate_collision(question_type: str, text: str, program: str) -> None:
    assert parse_choice(text, question_type) == words(program)


def test_adjective_order_does_not_change_the_filter_order() -> None:
    expected = words("objects green filter_color metal filter_material cube filter_shape unique")
    for text in ("the presence of the green metal cube", "the presence of the metal green cube"):
        assert parse_choice(text, "explanatory") == expected


def test_choice_program_depends_on_the_question_type_only_through_the_root() -> None:
    text = "the cube's colliding with the red sphere"
    explanatory = parse_choice(text, "explanatory")
    predictive = parse_choice(text, "predictive")
    assert explanatory[0] == "events" and predictive[0] == "all_events"
    assert explanatory[1:] == predictive[1:]


@pytest.mark.parametrize(
    ("text", "word", "position"),
    [
        ("What is the meaning of life?", "the", 8),
        ("Which of the following is responsible for the red cube?", "?", 54),
        ("Which of the following is responsible for the red blue cube's exit?", "blue", 50),
        ("What will happen if the cube is gone?", "is", 29),
        ("Which event will happen next? Really", "really", 30),
        ("", "<end>", 0),
        ("Which of the following is responsible for the 3 cubes?", "3", 46),
        ("Which of the following is responsible for the cubes' exit?", "'", 51),
        ("Which of the following is responsible for the golden cube's exit?", "golden", 46),
    ],
)
def test_bad_questions_raise_parse_error_naming_word_and_position(text: str, word: str, position: int) -> None:
    with pytest.raises(ParseError) as caught:
        parse_question(text)
    assert caught.value.word == word
    assert caught.value.position == position
    assert f"character {position}" in str(caught.value)
    assert caught.value.expected  # says what would have been accepted


@pytest.mark.parametrize(
    ("text", "question_type"),
    [
        ("the presence of the red cube", "predictive"),  # presence is explanatory-only
        ("the cube's entrance", "counterfactual"),  # candidate events are collisions
        ("the cube and the sphere", "explanatory"),  # missing verb
        ("the presence of", "explanatory"),
        ("the cube's colliding the sphere", "explanatory"),
    ],
)
def test_bad_choices_raise_parse_error(text: str, question_type: str) -> None:
    with pytest.raises(ParseError):
        parse_choice(text, question_type)


def test_unknown_question_type_is_a_value_error_naming_it() -> None:
    with pytest.raises(ValueError, match="question_type"):
        parse_choice("the presence of the cube", "descriptive")


@settings(max_examples=200, deadline=None)
@given(st.text(alphabet=st.sampled_from(list("abcdehilnorstuw '’s?,.3-")), max_size=60))
def test_any_text_parses_or_raises_parse_error(text: str) -> None:
    for parse in (parse_question, lambda t: parse_choice(t, "explanatory")):
        try:
            parse(text)
        except ParseError as error:
            assert 0 <= error.position <= len(text)


objects_strategy = st.builds(
    ObjectRef,
    color=st.none() | st.sampled_from(COLORS),
    material=st.none() | st.sampled_from(MATERIALS),
    shape=st.none() | st.sampled_from(SHAPES),
)


def render_object(obj: ObjectRef, adjective_order: list[str]) -> str:
    adjectives = [value for kind in adjective_order if (value := obj.attribute(kind)) and kind != "shape"]
    return " ".join(["the", *adjectives, obj.shape or "object"])


@settings(max_examples=150, deadline=None)
@given(
    first=objects_strategy,
    second=objects_strategy,
    form=st.sampled_from(
        [
            "the collision between {a} and {b}",
            "{a}'s colliding with {b}",
            "{a} colliding with {b}",
            "{a} collides with {b}",
            "{a} and {b} collide",
            "{a}'s entrance",
            "{a} entering the scene",
            "{a}'s exiting the scene",
            "{a}'s exit",
            "{a} exits the scene",
        ]
    ),
    adjective_order=st.permutations(["color", "material"]),
    capitalize=st.booleans(),
)
def test_rendered_events_parse_back_to_their_meaning(
    first: ObjectRef, second: ObjectRef, form: str, adjective_order: list[str], capitalize: bool
) -> None:
    text = form.format(a=render_object(first, adjective_order), b=render_object(second, adjective_order))
    if capitalize:
        text = text[0].upper() + text[1:]
    event = parse_choice_ast(text)
    assert isinstance(event, EventRef)
    if "{b}" in form:
        assert event == EventRef("collision", (first, second))
    else:
        assert event.objects == (first,)
        assert event.kind == ("in" if "ent" in form else "out")


@pytest.mark.parametrize("apostrophe", ["'", "\u2019"])
def test_tokenizer_splits_possessive_and_punctuation(apostrophe: str) -> None:
    tokens = tokenize(f"The Cube{apostrophe}s exit?")
    assert [t.text for t in tokens] == ["the", "cube", "'s", "exit", "?"]
    assert [t.position for t in tokens] == [0, 4, 8, 11, 15]


def test_vocabulary_agrees_with_the_world_types() -> None:

    assert set(COLORS) == set(WORLD_COLORS)
    assert set(MATERIALS) == set(WORLD_MATERIALS)
    assert set(SHAPES) == set(SHAPE_KINDS)


@pytest.mark.parametrize(
    ("official", "normalized"),
    [
        # CLEVRER's release form of a counterfactual question -> the generator's form.
        (f"all_events {RED_SPHERE} get_counterfact belong_to", f"{RED_SPHERE} counterfact_events belong_to"),
        (
            f"all_events {CUBE} filter_counterfact belong_to negate",
            f"{CUBE} counterfact_events belong_to negate",
        ),
        ("events objects get_col_partner", "events objects query_collision_partner"),
        # Not an object reference between all_events and the operator: left alone.
        ("all_events events filter_counterfact belong_to", "all_events events filter_counterfact belong_to"),
        (RED_SPHERE_CUBE, RED_SPHERE_CUBE),
    ],
)
def test_official_programs_are_normalized(official: str, normalized: str) -> None:
    assert normalize_program(official.split()) == words(normalized)


# ---------------------------------------------------------------- the real corpus


def test_real_clevrer_explanatory_subset_exact_match_at_least_99_percent() -> None:
    document = json.loads(SHARED_QUESTIONS.read_text())
    result = parse_question_file(document)
    summary = result.summary()
    assert summary["questions"]["with_official_program"] == 564
    assert summary["choices"]["with_official_program"] == 2256
    assert summary["questions"]["exact_match_rate"] >= 0.99, result.misses[:5]
    assert summary["choices"]["exact_match_rate"] >= 0.99, result.misses[:5]
    misses = len(result.misses)
    assert misses == (564 - summary["questions"]["exact"]) + (2256 - summary["choices"]["exact"])


# ---------------------------------------------------------------- file handling and the command


def _video(scene_index: int) -> dict:
    return {
        "scene_index": scene_index,
        "video_filename": f"video_{scene_index:05d}.mp4",
        "questions": [
            {
                "question_id": 0,
                "question_type": "descriptive",
                "question": "What is the shape of the object to collide with the cube?",
                "program": ["objects"],
                "answer": "sphere",
            },
            {
                "question_id": 1,
                "question_type": "explanatory",
                "question": REAL_QUESTIONS[0][0],
                "program": list(words(REAL_QUESTIONS[0][1])),
                "choices": [
                    {"choice_id": 0, "choice": text, "program": list(words(program)), "answer": "correct"}
                    for text, program in REAL_EXPLANATORY_CHOICES[:3]
                ]
                + [{"choice_id": 3, "choice": "the cube's mood", "program": ["objects"], "answer": "wrong"}],
            },
            {
                "question_id": 2,
                "question_type": "counterfactual",
                "question": "What will happen if the cube is removed?",
                "choices": [{"choice_id": 0, "choice": "The cube and the red sphere collide"}],
            },
        ],
    }


@pytest.mark.parametrize("layout", ["list", "dict"])
def test_parse_command_writes_programs_and_unparsed_texts(tmp_path: Path, layout: str, capsys) -> None:

    videos = [_video(10000), _video(10001)]
    document = videos if layout == "list" else {str(v["scene_index"]): {"questions": v["questions"]} for v in videos}
    source = tmp_path / "questions.json"
    source.write_text(json.dumps(document))
    target = tmp_path / "out" / "programs.json"

    assert main(["parse", str(source), "-o", str(target)]) == 0
    printed = capsys.readouterr().out
    output = json.loads(target.read_text())

    videos_out = output["questions"] if layout == "list" else list(output["questions"].values())
    assert isinstance(output["questions"], list if layout == "list" else dict)
    explanatory = videos_out[0]["questions"][1]
    assert explanatory["program"] == list(words(REAL_QUESTIONS[0][1]))
    assert explanatory["choices"][3]["program"] is None
    counterfactual = videos_out[0]["questions"][2]
    assert counterfactual["program"][-2:] == ["counterfact_events", "belong_to"]
    assert counterfactual["choices"][0]["program"][0] == "all_events"
    assert [item["text"] for item in output["unparsed"]] == ["the cube's mood", "the cube's mood"]
    assert "mood" in output["unparsed"][0]["error"]
    # 2 questions and 6 of 8 choices carry a matching official program.
    assert output["summary"]["questions"]["exact_match_rate"] == 1.0
    assert output["summary"]["choices"]["exact_match_rate"] == 0.75
    assert output["summary"]["skipped_questions"] == {"descriptive": 2}
    assert "75.00 %" in printed


@pytest.mark.parametrize(
    ("content", "message"),
    [
        ("not json", "not valid JSON"),
        ("[1, 2]", "document[0].questions"),
        ('{"7": {"questions": [{"question": 5}]}}', "question must be a string"),
        ("3", "list of {scene_index, questions}"),
    ],
)
def test_parse_command_rejects_bad_files_with_one_line(tmp_path: Path, content: str, message: str, capsys) -> None:

    source = tmp_path / "questions.json"
    source.write_text(content)
    assert main(["parse", str(source), "-o", str(tmp_path / "out.json")]) == 2
    error = capsys.readouterr().err
    assert message in error and "Traceback" not in error
    assert not (tmp_path / "out.json").exists()


def test_parse_command_missing_file(tmp_path: Path, capsys) -> None:

    assert main(["parse", str(tmp_path / "absent.json"), "-o", str(tmp_path / "out.json")]) == 2
    assert "not found" in capsys.readouterr().err


# ---------------------------------------------------------------- the scene generator's questions


def _random_program_scene(seed: int):
    """A random scene of object/event records (no MuJoCo): the generator's question input."""


    rng = np.random.default_rng(seed)
    n_objects = int(rng.integers(3, 7))
    # Distinct attribute triples, as in the generator's scenes: every object has a unique description.
    triples = [(c, m, s) for c in COLORS for m in MATERIALS for s in SHAPES]
    objects = tuple(
        ObjectRecord(i, *triples[index]) for i, index in enumerate(rng.permutation(len(triples))[:n_objects])
    )
    events = [EventRecord("in", (i,), int(rng.integers(0, 40))) for i in range(n_objects)]
    pairs = [(a, b) for a in range(n_objects) for b in range(a + 1, n_objects)]
    for index in rng.permutation(len(pairs))[: int(rng.integers(2, 6))]:
        events.append(EventRecord("collision", pairs[index], int(rng.integers(40, 200))))
    for i in range(n_objects):
        if rng.uniform() < 0.4:
            events.append(EventRecord("out", (i,), int(rng.integers(60, 200))))
    replays = {
        removed: [
            EventRecord("collision", pairs[index], int(rng.integers(40, 127)))
            for index in rng.permutation(len(pairs))[: int(rng.integers(0, 4))]
            if removed not in pairs[index]
        ]
        for removed in range(n_objects)
    }
    return ProgramScene(objects, tuple(events), 128, counterfactual=lambda removed: replays[removed])


def test_every_generator_question_and_choice_parses_to_the_generators_program() -> None:
    """Runs synth/questions.py's templates (pure Python, no MuJoCo) and parses every text back."""

    seen: Counter[str] = Counter()
    for seed in range(40):
        scene = _random_program_scene(seed)
        for question in scene_questions(scene, np.random.default_rng(seed)):
            parsed = parse_question(question["question"])
            assert parsed.question_type == question["question_type"], question["question"]
            assert parsed.program == tuple(question["program"]), question["question"]
            for choice in question["choices"]:
                assert parse_choice(choice["choice"], parsed.question_type) == tuple(choice["program"]), choice
                seen[f"{parsed.question_type} choice"] += 1
            seen[parsed.question_type] += 1
    # The check is only meaningful if every question type actually occurred.
    for kind in ("explanatory", "predictive", "counterfactual"):
        assert seen[kind] > 0 and seen[f"{kind} choice"] > 0, seen


def test_clevrer_release_counterfactual_form_answers_like_the_canonical_form() -> None:
    """``all_events X filter_counterfact belong_to`` (CLEVRER's files) and ``X
    counterfact_events belong_to`` (ours) score every candidate collision alike."""

    answers: Counter[str] = Counter()
    for seed in range(20):
        scene = _random_program_scene(seed)
        for removed in scene.objects:
            removed_ref = ObjectRef(removed.color, removed.material, removed.shape)
            canonical = parse_question(f"What will happen if {render_object(removed_ref, ['color', 'material'])} is removed?")
            release = ("all_events", *canonical.program[:-2], "filter_counterfact", "belong_to")
            assert normalize_program(release) == canonical.program
            for a in scene.objects:
                for b in scene.objects:
                    if a.id >= b.id or removed.id in (a.id, b.id):
                        continue
                    choice = parse_choice(
                        f"the {a.color} {a.material} {a.shape} collides with the {b.color} {b.material} {b.shape}",
                        "counterfactual",
                    )
                    ours = execute(list(choice + canonical.program), scene)
                    assert execute(list(choice + release), scene) == ours
                    answers[ours] += 1
    assert answers["yes"] > 10 and answers["no"] > 10, answers  # both outcomes exercised


# Plain-word paraphrases a new user writes, each with the CLEVRER wording it means.
QUESTION_PARAPHRASES = [
    ("What would happen if the red cube were removed?", "What will happen if the red cube is removed?"),
    ("Which of the following would not happen without the blue block?", "Which of the following will not happen without the blue cube?"),
    ("What happens if we remove the red ball?", "What will happen if the red sphere is removed?"),
    ("If you remove the grey ball, what happens?", "If the gray sphere is removed, what will happen?"),
    ("What would happen if the metallic cylinder was taken away?", "What will happen if the metal cylinder is removed?"),
    ("What happens next?", "What will happen next?"),
    ("What caused the collision between the red ball and the cube?",
     "What is responsible for the collision between the red sphere and the cube?"),
    ("Which of the following was not responsible for the ball's exit?",
     "Which of the following is not responsible for the sphere's exit?"),
]
CHOICE_PARAPHRASES = [
    ("The red ball hits the blue block", "The red sphere collides with the blue cube", "predictive"),
    ("The red ball will hit the blue block", "The red sphere will collide with the blue cube", "predictive"),
    ("The ball bumps into the cylinder", "The sphere collides with the cylinder", "counterfactual"),
    ("The ball would run into the cylinder", "The sphere collides with the cylinder", "counterfactual"),
    ("The ball and the block hit each other", "The sphere and the cube collide", "counterfactual"),
    ("The block leaves the scene", "The cube exits the scene", "explanatory"),
    ("the cube crashes into the sphere", "the cube's colliding with the sphere", "explanatory"),
]


@pytest.mark.parametrize(("plain", "canonical"), QUESTION_PARAPHRASES)
def test_plain_word_questions_mean_the_clevrer_wording(plain: str, canonical: str) -> None:
    assert parse_question(plain) == parse_question(canonical)


@pytest.mark.parametrize(("plain", "canonical", "question_type"), CHOICE_PARAPHRASES)
def test_plain_word_choices_mean_the_clevrer_wording(plain: str, canonical: str, question_type: str) -> None:
    assert parse_choice(plain, question_type) == parse_choice(canonical, question_type)


def test_paraphrase_errors_still_name_the_word() -> None:
    with pytest.raises(ParseError) as caught:
        parse_question("What would happen if the red cube were destroyed?")
    assert caught.value.word == "were" and "were removed" in caught.value.expected
