"""Answers and their evidence: frozen records, JSON conversion and text rendering.

An :class:`Answer` holds one verdict per choice ("correct" / "wrong", or None
when the choice could not be decided, with the reason), the facts each
verdict rests on (events with frames, rollout ids, grounded object ids) and
the tool calls (by index into the video's call log) that produced them.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any, Literal, Mapping, Sequence

from planner.client import ToolCall
from planner.grammar import ParseError
from planner.grounding import Grounding, WorldObject, ground, program_references
from planner.parser import parse_question

Verdict = Literal["correct", "wrong"]


@dataclass(frozen=True)
class ChoiceAnswer:
    """The verdict on one choice.

    verdict: None when undecided (``error`` says why: unparsed text, a world
    without objects, a program that does not apply).
    facts: human-readable statements the verdict rests on.
    tool_calls: indices into the video's tool-call log.
    """

    choice_id: int
    text: str
    program: tuple[str, ...] | None
    verdict: Verdict | None
    facts: tuple[str, ...] = ()
    tool_calls: tuple[int, ...] = ()
    error: str | None = None

    def to_dict(self) -> dict[str, Any]:
        return {"choice_id": self.choice_id, "choice": self.text, "program": None if self.program is None else list(self.program),
                "verdict": self.verdict, "facts": list(self.facts), "tool_calls": list(self.tool_calls), "error": self.error}


@dataclass(frozen=True)
class Answer:
    """A multiple-choice question answered against one world.

    method: "program" (the offline executor), "trajectory_only" (the
    ablation: counterfactuals from factual events) or "vlm".
    facts: statements shared by all choices (the explained event, the
    rollout used, ...). tool_calls: every call the answer used.
    """

    question: str
    question_type: str | None
    program: tuple[str, ...] | None
    choices: tuple[ChoiceAnswer, ...]
    method: str = "program"
    groundings: tuple[Grounding, ...] = ()
    facts: tuple[str, ...] = ()
    tool_calls: tuple[int, ...] = ()
    error: str | None = None
    seconds: float = 0.0
    extra: Mapping[str, Any] = field(default_factory=dict)

    @property
    def verdicts(self) -> list[Verdict | None]:
        return [c.verdict for c in self.choices]

    def to_dict(self, calls: Sequence[ToolCall] | None = None) -> dict[str, Any]:
        """JSON-ready; with ``calls`` (the video's log) the cited calls are inlined."""
        document: dict[str, Any] = {
            "question": self.question, "question_type": self.question_type,
            "program": None if self.program is None else list(self.program), "method": self.method,
            "groundings": [g.to_dict() for g in self.groundings], "facts": list(self.facts),
            "choices": [c.to_dict() for c in self.choices], "tool_calls": list(self.tool_calls),
            "error": self.error, "seconds": round(self.seconds, 4),
        }
        if self.extra:
            document["extra"] = dict(self.extra)
        if calls is not None:
            document["tool_call_log"] = [calls[i].to_dict() for i in self.tool_calls if 0 <= i < len(calls)]
        return document


FALSE_PREMISE = "false premise"


def describe_objects(objects: Sequence[WorldObject]) -> str:
    """"object 0 (red metal cylinder), object 1 (...)": the world's objects in words."""
    return ", ".join(obj.describe() for obj in objects) or "no objects"


def refuse_false_premise(answer: Answer, objects: Sequence[WorldObject]) -> Answer:
    """``answer`` unless its question names an object the world does not have.

    "What happens if the red cube is removed?" in a world without a red cube
    (its attributes taken as given, no perceived beliefs: planner.grounding's
    ``absent``) has no true answer: every choice would be judged on a premise that does
    not hold. Then the answer says so plainly (``error`` starts with "false
    premise") and judges no choice. Choices naming absent objects are not
    affected (they are simply not among the world's events).
    """
    program = answer.program
    if program is None:  # a model's answer: the question's program from its text, if it parses
        try:
            program = parse_question(answer.question).program
        except ParseError:
            return answer
    missing = [g for g in (ground(q, objects) for q in program_references(program)) if g.absent or g.status == "undecided"]
    if not missing:
        return answer
    names = " and ".join(g.reference for g in missing)
    message = (f"{FALSE_PREMISE}: the world has no {names.removeprefix('the ')}; its objects are {describe_objects(objects)}. "
               "No choice is judged, since each would rest on an object that is not there.")
    refused = tuple(replace(c, verdict=None, error=f"not judged: the question names {names}, which the world does not have")
                    for c in answer.choices)
    return replace(answer, choices=refused, error=message)


def readable(value: Any) -> str:
    """A value of a tool result as a person reads it: "none" for null, 3 significant digits, lists unbracketed when short."""
    if value is None:
        return "none"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, float):
        return f"{value:.3g}"
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(readable(v) for v in value) + "]"
    if isinstance(value, Mapping):
        return "{" + ", ".join(f"{k}: {readable(v)}" for k, v in value.items()) + "}"
    return str(value)


def render_answer(answer: Answer, calls: Sequence[ToolCall] = (), truth: Sequence[str | None] | None = None) -> str:
    """Plain-text rendering: verdict per choice with its facts, the tool calls, optionally the ground truth.

    A question-level error (an unparsed question, a false premise) comes
    first, right under the question, so it is not missed.
    """
    lines = [f"Q ({answer.question_type or '?'}): {answer.question}"]
    if answer.error:
        lines.append(f"  ! {answer.error}")
    if answer.program is not None:
        lines.append(f"  program: {' '.join(answer.program)}")
    for grounding in answer.groundings:
        lines.append(f"  grounding: {grounding.message()}")
    for fact in answer.facts:
        lines.append(f"  fact: {fact}")
    for k, choice in enumerate(answer.choices):
        verdict = choice.verdict or "undecided"
        mark = ""
        if truth is not None and k < len(truth) and truth[k] is not None:
            mark = f"   [truth: {truth[k]}{'' if truth[k] == choice.verdict else '  <-- MISMATCH'}]"
        lines.append(f"  ({k}) {choice.text!r}: {verdict.upper()}{mark}")
        for fact in choice.facts:
            lines.append(f"        because: {fact}")
        if choice.error:
            lines.append(f"        error: {choice.error}")
    cited = [calls[i] for i in answer.tool_calls if 0 <= i < len(calls)]
    if cited:
        lines.append("  tool calls:")
        for call in cited:
            arguments = ", ".join(f"{k}={readable(v)}" for k, v in call.arguments.items()) or "-"
            result = ", ".join(f"{k}={readable(v)}" for k, v in call.digest.items())
            lines.append(f"    #{call.index} {call.tool}({arguments}) -> {call.status} {result} [{call.duration_ms:.1f} ms]")
    return "\n".join(lines)
