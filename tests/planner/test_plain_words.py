"""Asking in plain words: false premises said plainly, readable evidence, `ask --help` shows what can be asked."""

from __future__ import annotations

import subprocess
import sys

from planner.answer import Answer, ChoiceAnswer, readable, refuse_false_premise, render_answer
from planner.grounding import WorldObject
from planner.parser import parse_question

OBJECTS = (WorldObject(0, "red", "metal", "cylinder"), WorldObject(1, "blue", "rubber", "sphere"))


def _answer(question: str, program: bool = True) -> Answer:
    parsed = parse_question(question)
    choices = (ChoiceAnswer(0, "The blue ball hits the red cylinder", None, "correct"),
               ChoiceAnswer(1, "The red cylinder exits the scene", None, "wrong"))
    return Answer(question, parsed.question_type, parsed.program if program else None, choices)


def test_a_question_about_an_absent_object_is_refused_plainly():
    refused = refuse_false_premise(_answer("What would happen if the red cube were removed?"), OBJECTS)
    assert refused.error.startswith("false premise: the world has no red cube")
    assert "object 0 (red metal cylinder)" in refused.error
    assert refused.verdicts == [None, None] and all("red cube" in c.error for c in refused.choices)
    lines = render_answer(refused).splitlines()
    assert lines[1].startswith("  ! false premise")  # first thing under the question
    # a model's answer (no program) is checked from the question's text
    assert refuse_false_premise(_answer("What happens if we remove the green ball?", program=False), OBJECTS).verdicts == [None, None]


def test_a_question_about_present_objects_keeps_its_verdicts():
    answer = _answer("What would happen if the blue ball were removed?")
    assert refuse_false_premise(answer, OBJECTS) is answer
    predictive = _answer("What happens next?")
    assert refuse_false_premise(predictive, OBJECTS) is predictive


def test_evidence_values_read_as_words():
    assert readable(None) == "none" and readable(0.011888) == "0.0119" and readable(True) == "yes"
    assert readable(["collision", "in"]) == "[collision, in]" and readable({"a": 2.292582}) == "{a: 2.29}"


def test_ask_help_shows_what_can_be_asked():
    completed = subprocess.run([sys.executable, "-m", "physmind.cli", "ask", "--help"], capture_output=True, text=True, timeout=60)
    assert completed.returncode == 0
    for phrase in ("What would happen if <object> were removed?", "hits", "bumps into", "ball = sphere", "block = cube",
                   "false premise"):
        assert phrase in completed.stdout, phrase
