"""CLEVRER-style English -> CLEVRER programs (postfix token lists).

``planner.grammar`` turns text into a small syntax tree; this module compiles
the tree into the programs of CLEVRER's executor (operator names as in
DESIGN.md) and runs whole question files.

Program forms (``+`` is list concatenation; ``OBJ(x)`` is an object reference):

* ``OBJ(the green metal cube)`` = ``objects green filter_color metal
  filter_material cube filter_shape unique`` -- filters always in the order
  colour, material, shape; absent attributes are left out.
* event with root ``R``: collision ``[R] + OBJ(a) + [filter_collision] +
  OBJ(b) + [filter_collision, unique]``; entering ``[R] + OBJ(a) +
  [filter_in, unique]``; exiting likewise with ``filter_out``.
* explanatory question: ``[events] + event(R=events) + [filter_ancestor,
  belong_to] (+ [negate])``; its choices: ``OBJ(x)`` for "the presence of x",
  otherwise ``event(R=events)``.
* predictive question: ``[unseen_events, belong_to] (+ [negate])``.
* counterfactual question: ``OBJ(removed) + [counterfact_events, belong_to]
  (+ [negate])`` -- the form of this project's scene generator
  (synth/questions.py). CLEVRER's release files write the equivalent
  ``all_events OBJ(removed) get_counterfact belong_to``; ``normalize_program``
  maps that form onto this one before comparing.
* predictive and counterfactual choices: ``event(R=all_events)`` -- the choice
  names a candidate pair from all possible collisions, which exists whether
  or not it happens; the question's list decides membership. Only collisions
  are candidate events there (CLEVRER's ``all_events`` enumerates pairs).

A choice is scored by running ``choice.program + question.program``.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field
from typing import Any, Iterator, Mapping, Sequence

from planner.grammar import (
    EventRef,
    ObjectRef,
    ParseError,
    PresenceRef,
    QuestionAst,
    parse_choice_ast,
    parse_question_ast,
    tokenize,
)
from planner.vocabulary import (
    EVENT_FILTERS,
    FILTER_ORDER,
    OFFICIAL_OPERATOR_ALIASES,
    OP_ALL_EVENTS,
    OP_BELONG_TO,
    OP_COUNTERFACT_EVENTS,
    OP_EVENTS,
    OP_FILTER_ANCESTOR,
    OP_FILTER_COUNTERFACT,
    OP_NEGATE,
    OP_OBJECTS,
    OP_UNIQUE,
    OP_UNSEEN_EVENTS,
    QUESTION_TYPES,
    QuestionType,
)
from planner.vocabulary import ATTRIBUTE_WORDS, COLORS, MATERIALS, SHAPES

Program = tuple[str, ...]


@dataclass(frozen=True)
class ParsedQuestion:
    """A parsed question: its type (decides how its choices compile) and program."""

    question_type: QuestionType
    negated: bool
    program: Program


def object_program(obj: ObjectRef) -> Program:
    """``objects [value filter_*]... unique`` in the fixed colour/material/shape order."""
    tokens = [OP_OBJECTS]
    for kind, operator in FILTER_ORDER:
        value = obj.attribute(kind)
        if value is not None:
            tokens += [value, operator]
    tokens.append(OP_UNIQUE)
    return tuple(tokens)


def event_program(event: EventRef, root: str) -> Program:
    """Select one event from the list pushed by ``root`` (``events``/``all_events``)."""
    operator = EVENT_FILTERS[event.kind]
    tokens = [root]
    for obj in event.objects:
        tokens += [*object_program(obj), operator]
    tokens.append(OP_UNIQUE)
    return tuple(tokens)


def question_program(ast: QuestionAst) -> Program:
    if ast.question_type == "explanatory":
        assert ast.target is not None
        tokens = [OP_EVENTS, *event_program(ast.target, OP_EVENTS), OP_FILTER_ANCESTOR, OP_BELONG_TO]
    elif ast.question_type == "predictive":
        tokens = [OP_UNSEEN_EVENTS, OP_BELONG_TO]
    else:
        assert ast.removed is not None
        tokens = [*object_program(ast.removed), OP_COUNTERFACT_EVENTS, OP_BELONG_TO]
    if ast.negated:
        tokens.append(OP_NEGATE)
    return tuple(tokens)


def parse_question(text: str) -> ParsedQuestion:
    """Parse an explanatory, predictive or counterfactual question.

    Raises:
        ParseError: the text is outside the grammar (names position and word).
    """
    ast = parse_question_ast(text)
    return ParsedQuestion(ast.question_type, ast.negated, question_program(ast))


def parse_choice(text: str, question_type: str) -> Program:
    """Parse one choice of a question of ``question_type``.

    Raises:
        ValueError: ``question_type`` is not explanatory/predictive/counterfactual.
        ParseError: the text is outside the grammar, or names something the
            question type cannot ask about ("the presence of ..." outside
            explanatory questions; entering/exiting in predictive or
            counterfactual choices).
    """
    if question_type not in QUESTION_TYPES:
        raise ValueError(f"question_type must be one of {QUESTION_TYPES}, got {question_type!r}")
    ast = parse_choice_ast(text)
    if question_type == "explanatory":
        if isinstance(ast, PresenceRef):
            return object_program(ast.obj)
        return event_program(ast, OP_EVENTS)
    first = tokenize(text)[0]
    if isinstance(ast, PresenceRef):
        raise ParseError(text, first.position, first.text, [f"an event ({question_type} choices name events)"])
    if ast.kind != "collision":
        raise ParseError(text, first.position, first.text, [f"a collision ({question_type} choices are collisions)"])
    return event_program(ast, OP_ALL_EVENTS)


def normalize_program(program: Sequence[Any]) -> Program:
    """An official program in this project's canonical form, for comparison.

    CLEVRER's release-file operator spellings become DESIGN.md's
    (``get_counterfact`` -> ``filter_counterfact`` ...), and CLEVRER's
    counterfactual question form ``all_events OBJ(X) filter_counterfact
    belong_to [negate]`` becomes the equivalent ``OBJ(X) counterfact_events
    belong_to [negate]``: both ask whether the choice's collision pair collides
    in the replay without X (``all_events`` holds collision pairs only).
    """
    tokens = [OFFICIAL_OPERATOR_ALIASES.get(str(token), str(token)) for token in program]
    negated = tokens[-1:] == [OP_NEGATE]
    core = tokens[:-1] if negated else tokens
    if (
        len(core) >= 5
        and core[0] == OP_ALL_EVENTS
        and core[1] == OP_OBJECTS
        and core[-3:] == [OP_UNIQUE, OP_FILTER_COUNTERFACT, OP_BELONG_TO]
        and OP_OBJECTS not in core[2:-3]  # exactly one object reference in between
    ):
        tokens = [*core[1:-2], OP_COUNTERFACT_EVENTS, OP_BELONG_TO] + ([OP_NEGATE] if negated else [])
    return tuple(tokens)


# ---------------------------------------------------------------- question files


@dataclass(frozen=True)
class Miss:
    """A text whose parsed program differs from the official one (or did not parse)."""

    question_type: str
    kind: str  # "question" | "choice"
    scene_index: str
    question_id: Any
    choice_id: Any
    text: str
    official: Program
    parsed: Program | None
    error: str | None


@dataclass
class _Tally:
    total: int = 0
    with_official: int = 0
    exact: int = 0


@dataclass(frozen=True)
class TypeMatch:
    """Exact-match counts for one question type (only texts that carry an official program count)."""

    questions_total: int
    questions_with_official: int
    questions_exact: int
    choices_total: int
    choices_with_official: int
    choices_exact: int

    @staticmethod
    def rate(exact: int, with_official: int) -> float | None:
        return exact / with_official if with_official else None


@dataclass(frozen=True)
class FileParse:
    """The result of parsing a question file.

    ``document`` has the input's structure (list or dict keyed by scene index)
    with every question's and choice's ``program`` replaced by the parsed one
    (``None`` when unparsed) and the input program kept as ``official_program``.
    """

    document: Any
    unparsed: tuple[dict[str, Any], ...]
    per_type: Mapping[str, TypeMatch]
    misses: tuple[Miss, ...]
    skipped: Mapping[str, int] = field(default_factory=dict)

    def summary(self) -> dict[str, Any]:
        def totals(prefix: str) -> dict[str, Any]:
            with_official = sum(getattr(m, f"{prefix}_with_official") for m in self.per_type.values())
            exact = sum(getattr(m, f"{prefix}_exact") for m in self.per_type.values())
            return {
                "total": sum(getattr(m, f"{prefix}_total") for m in self.per_type.values()),
                "with_official_program": with_official,
                "exact": exact,
                "exact_match_rate": TypeMatch.rate(exact, with_official),
            }

        return {
            "questions": totals("questions"),
            "choices": totals("choices"),
            "per_type": {
                question_type: {
                    "questions": {
                        "total": m.questions_total,
                        "with_official_program": m.questions_with_official,
                        "exact": m.questions_exact,
                        "exact_match_rate": TypeMatch.rate(m.questions_exact, m.questions_with_official),
                    },
                    "choices": {
                        "total": m.choices_total,
                        "with_official_program": m.choices_with_official,
                        "exact": m.choices_exact,
                        "exact_match_rate": TypeMatch.rate(m.choices_exact, m.choices_with_official),
                    },
                }
                for question_type, m in sorted(self.per_type.items())
            },
            "unparsed": len(self.unparsed),
            "skipped_questions": dict(self.skipped),
        }


def iter_videos(document: Any) -> Iterator[tuple[str, Mapping[str, Any]]]:
    """(scene index, video record) pairs of a CLEVRER question document.

    Accepts CLEVRER's list ``[{scene_index, video_filename, questions}]``, the
    dict keyed by scene index ``{"8995": {"questions": [...]}}``, or a single
    video record ``{"scene_index": ..., "questions": [...]}``.

    Raises:
        ValueError: naming the field when the document has neither layout.
    """
    if isinstance(document, list):
        for position, video in enumerate(document):
            if not isinstance(video, Mapping) or not isinstance(video.get("questions"), list):
                raise ValueError(f"document[{position}].questions must be a list of questions")
            yield str(video.get("scene_index", position)), video
    elif isinstance(document, Mapping) and "questions" in document:
        if not isinstance(document["questions"], list):
            raise ValueError("questions must be a list of questions")
        yield str(document.get("scene_index", 0)), document
    elif isinstance(document, Mapping):
        for key, video in document.items():
            if not isinstance(video, Mapping) or not isinstance(video.get("questions"), list):
                raise ValueError(f"document[{key!r}].questions must be a list of questions")
            yield str(key), video
    else:
        raise ValueError(
            "a question file must be a list of {scene_index, questions} records "
            f"or a dict keyed by scene index, got {type(document).__name__}"
        )


def _text_field(record: Mapping[str, Any], name: str, where: str) -> str:
    value = record.get(name)
    if not isinstance(value, str):
        raise ValueError(f"{where}.{name} must be a string, got {type(value).__name__}")
    return value


def parse_question_file(document: Any) -> FileParse:
    """Parse every question and choice text of a CLEVRER question document.

    Descriptive questions (CLEVRER's open-ended kind, outside this grammar)
    are copied unchanged and counted under ``skipped``. Unparsable texts get
    ``program: None`` and are listed in ``unparsed`` with the parser's message.

    Raises:
        ValueError: the document's layout is wrong (names the field).
    """
    tallies: dict[str, dict[str, _Tally]] = {}
    unparsed: list[dict[str, Any]] = []
    misses: list[Miss] = []
    skipped: Counter[str] = Counter()

    def tally(question_type: str, kind: str) -> _Tally:
        return tallies.setdefault(question_type, {"question": _Tally(), "choice": _Tally()})[kind]

    def record(question_type: str, kind: str, scene: str, question_id: Any, choice_id: Any,
               text: str, official: Any, parsed: Program | None, error: str | None) -> None:
        counts = tally(question_type, kind)
        counts.total += 1
        if error is not None:
            unparsed.append({"scene_index": scene, "question_id": question_id, "choice_id": choice_id,
                             "kind": kind, "text": text, "error": error})
        if isinstance(official, list):
            counts.with_official += 1
            expected = normalize_program(official)
            if parsed == expected:
                counts.exact += 1
            else:
                misses.append(Miss(question_type, kind, scene, question_id, choice_id, text,
                                   expected, parsed, error))

    def parse_video(scene: str, video: Mapping[str, Any]) -> dict[str, Any]:
        out_questions = []
        for q_index, question in enumerate(video["questions"]):
            where = f"scene {scene} questions[{q_index}]"
            if not isinstance(question, Mapping):
                raise ValueError(f"{where} must be an object")
            declared = question.get("question_type")
            if declared == "descriptive":
                skipped["descriptive"] += 1
                out_questions.append(dict(question))
                continue
            text = _text_field(question, "question", where)
            question_id = question.get("question_id", q_index)
            out = dict(question)
            if "program" in question:
                out["official_program"] = question["program"]
            try:
                parsed = parse_question(text)
                question_type: str | None = parsed.question_type
                program: Program | None = parsed.program
                error = None
            except ParseError as exc:
                question_type = declared if declared in QUESTION_TYPES else None
                program, error = None, str(exc)
            record(question_type or str(declared), "question", scene, question_id, None, text,
                   question.get("program"), program, error)
            out["program"] = list(program) if program is not None else None
            if declared is None and question_type is not None:
                out["question_type"] = question_type
            choices = question.get("choices", [])
            if not isinstance(choices, list):
                raise ValueError(f"{where}.choices must be a list")
            out_choices = []
            for c_index, choice in enumerate(choices):
                c_where = f"{where}.choices[{c_index}]"
                if not isinstance(choice, Mapping):
                    raise ValueError(f"{c_where} must be an object")
                c_text = _text_field(choice, "choice", c_where)
                choice_id = choice.get("choice_id", c_index)
                c_out = dict(choice)
                if "program" in choice:
                    c_out["official_program"] = choice["program"]
                c_program: Program | None = None
                if question_type is None:
                    c_error: str | None = "question type unknown: the question did not parse and names no question_type"
                else:
                    try:
                        c_program, c_error = parse_choice(c_text, question_type), None
                    except ParseError as exc:
                        c_error = str(exc)
                record(question_type or str(declared), "choice", scene, question_id, choice_id, c_text,
                       choice.get("program"), c_program, c_error)
                c_out["program"] = list(c_program) if c_program is not None else None
                out_choices.append(c_out)
            if "choices" in question:
                out["choices"] = out_choices
            out_questions.append(out)
        return {**video, "questions": out_questions}

    if isinstance(document, list):
        output: Any = [parse_video(scene, video) for scene, video in iter_videos(document)]
    elif isinstance(document, Mapping) and "questions" in document:
        output = parse_video(*next(iter_videos(document)))
    else:
        output = {scene: parse_video(scene, video) for scene, video in iter_videos(document)}

    per_type = {
        question_type: TypeMatch(
            counts["question"].total, counts["question"].with_official, counts["question"].exact,
            counts["choice"].total, counts["choice"].with_official, counts["choice"].exact,
        )
        for question_type, counts in tallies.items()
    }
    return FileParse(output, tuple(unparsed), per_type, tuple(misses), dict(skipped))


__all__ = [
    "FileParse",
    "Miss",
    "ParseError",
    "ParsedQuestion",
    "Program",
    "TypeMatch",
    "event_program",
    "iter_videos",
    "normalize_program",
    "object_program",
    "parse_choice",
    "parse_question",
    "parse_question_file",
    "question_program",
]


def question_guide() -> str:
    """What can be asked, in words: the forms the grammar accepts and its vocabulary (for ``ask --help``)."""
    synonyms = ", ".join(f"{word} = {value}" for word, (_, value) in ATTRIBUTE_WORDS.items() if word != value)
    return "\n".join([
        "What can be asked (one verdict per --choice; words in any case):",
        "  explanatory     Which of the following is [not] responsible for <event>?   /  What caused <event>?",
        "  predictive      What will happen next?   /  Which event will happen next?",
        "  counterfactual  What would happen if <object> were removed?   /  ... if we remove <object>?  /  ... without <object>?",
        "                  (also: will / would / happens, is / was / were removed, taken away)",
        "  choices         <object> collides with / hits / bumps into / runs into <object>",
        "                  <object> and <object> collide / hit each other",
        "                  <object> enters / exits / leaves the scene   (explanatory: also 'the presence of <object>')",
        "  <object>        'the' + up to one colour, material and shape, ending in a shape or 'object':",
        "                  'the red cube', 'the metal ball', 'the green object'",
        f"  colours         {', '.join(COLORS)}",
        f"  materials       {', '.join(MATERIALS)}",
        f"  shapes          {', '.join(SHAPES)}",
        f"  plain words     {synonyms}",
        "A question about an object the world does not have is answered with 'false premise', never with verdicts.",
    ])
