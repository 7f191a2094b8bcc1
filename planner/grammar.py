"""Tokenizer and recursive-descent grammar for CLEVRER-style questions.

The grammar (EBNF; words are matched case-insensitively, ``'s`` is its own
token, the word tables live in ``planner.vocabulary``)::

    question       := explanatory | future
    explanatory    := WH ("is" | "was") ["not"] "responsible" "for" event ["?"]
                    | WH "caused" event ["?"]
    future         := WH happen tail ["?"]                            (* tail decides *)
                    | condition [","] WH happen ["?"]
    happen         := ("will" | "would") ["not"] "happen" | "happens"
    tail           := "next"                                          (* predictive *)
                    | condition                                       (* counterfactual *)
    condition      := "if" object REMOVAL_PHRASE                      (* "is removed", "were taken away" *)
                    | "if" ("we" | "you") "remove" object | "without" object
    WH             := "which" "of" "the" "following" | "which" "event" | "what"

    choice         := "the" "presence" "of" object                    (* explanatory only *)
                    | event
    event          := "the" "collision" "between" object "and" object
                    | object "and" object PAIR_COLLISION_PHRASE       (* "... collide", "... hit each other" *)
                    | object ["'s"] SUBJECT_EVENT_PHRASE [object]     (* object iff collision *)
    object         := "the" attribute* (SHAPE | "object" | "thing")

An ``object`` carries at most one colour, one material and one shape, in any
adjective order. Parsing produces the small syntax tree below; compiling it to
a CLEVRER program is ``planner.parser``'s job.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Iterable, Sequence

from planner.vocabulary import (
    ATTRIBUTE_WORDS,
    FUTURE_MODALS,
    REMOVAL_PHRASES,
    REMOVER_WORDS,
    GENERIC_OBJECT_NOUNS,
    PAIR_COLLISION_PHRASES,
    SUBJECT_EVENT_PHRASES,
    WH_PHRASES,
    AttributeKind,
    EventKind,
    QuestionType,
)

POSSESSIVE = "'s"
_PUNCTUATION = frozenset("?,.!")
_APOSTROPHES = frozenset("'\u2019")


class ParseError(ValueError):
    """Text outside the grammar: names the character position and the word.

    Attributes:
        text: the whole input text.
        position: character offset of the offending token (len(text) at the end).
        word: the offending token, or ``"<end>"``.
        expected: what the grammar would have accepted there.
    """

    def __init__(self, text: str, position: int, word: str, expected: Sequence[str]) -> None:
        self.text = text
        self.position = position
        self.word = word
        self.expected = tuple(expected)
        wanted = " or ".join(repr(item) for item in self.expected) or "nothing"
        super().__init__(
            f"cannot parse {text!r}: at character {position}, word {word!r}, expected {wanted}"
        )


@dataclass(frozen=True)
class Token:
    """One word or punctuation mark, lower-cased, with its character offset."""

    text: str
    position: int


@dataclass(frozen=True)
class ObjectRef:
    """A definite object description: "the green metal cube", "the sphere"."""

    color: str | None = None
    material: str | None = None
    shape: str | None = None

    def attribute(self, kind: AttributeKind) -> str | None:
        return {"color": self.color, "material": self.material, "shape": self.shape}[kind]


@dataclass(frozen=True)
class EventRef:
    """An event: a collision of two objects, or one object entering/exiting."""

    kind: EventKind
    objects: tuple[ObjectRef, ...]


@dataclass(frozen=True)
class PresenceRef:
    """"the presence of <object>": an explanatory choice naming an object."""

    obj: ObjectRef


@dataclass(frozen=True)
class QuestionAst:
    """The meaning of a question.

    ``target`` is the explained event (explanatory), ``removed`` the removed
    object (counterfactual); predictive questions carry neither.
    """

    question_type: QuestionType
    negated: bool
    target: EventRef | None = None
    removed: ObjectRef | None = None


def tokenize(text: str) -> list[Token]:
    """Split text into lower-cased words, ``'s`` and punctuation marks.

    Raises:
        ParseError: on a character that no token can contain (digits, quotes,
            brackets, ...), naming its position.
    """
    if not isinstance(text, str):
        raise ParseError(repr(text), 0, repr(text), ["a string"])
    tokens: list[Token] = []
    index = 0
    while index < len(text):
        char = text[index]
        if char.isspace():
            index += 1
        elif char in _PUNCTUATION:
            tokens.append(Token(char, index))
            index += 1
        elif char in _APOSTROPHES:
            # Only the possessive "'s" is part of the language.
            follows_word = bool(tokens) and tokens[-1].text not in _PUNCTUATION
            is_s = text[index + 1 : index + 2].lower() == "s"
            at_word_end = not text[index + 2 : index + 3].isalpha()
            if not (follows_word and is_s and at_word_end):
                raise ParseError(text, index, char, ["the possessive 's"])
            tokens.append(Token(POSSESSIVE, index))
            index += 2
        elif char.isascii() and char.isalpha():
            start = index
            while index < len(text) and text[index].isascii() and text[index].isalpha():
                index += 1
            tokens.append(Token(text[start:index].lower(), start))
        else:
            raise ParseError(text, index, char, ["a word", "'s", "?", ","])
    return tokens


class _Cursor:
    """A position in a token list with the lookahead helpers the grammar needs."""

    def __init__(self, text: str) -> None:
        self.text = text
        self.tokens = tokenize(text)
        self.index = 0
        # Alternatives tried (and not taken) at each token index, so an error
        # lists everything the grammar would have accepted there.
        self._tried: dict[int, set[str]] = {}

    def word(self, offset: int = 0) -> str | None:
        index = self.index + offset
        return self.tokens[index].text if index < len(self.tokens) else None

    def error(self, expected: Iterable[str]) -> ParseError:
        wanted = sorted(set(expected) | self._tried.get(self.index, set()))
        if self.index < len(self.tokens):
            token = self.tokens[self.index]
            return ParseError(self.text, token.position, token.text, wanted)
        return ParseError(self.text, len(self.text), "<end>", wanted)

    def at(self, *words: str) -> bool:
        """True when the next tokens are exactly ``words`` (nothing consumed)."""
        return all(self.word(offset) == word for offset, word in enumerate(words))

    def accept(self, *words: str) -> bool:
        if self.at(*words):
            self.index += len(words)
            return True
        self._tried.setdefault(self.index, set()).add(" ".join(words))
        return False

    def expect(self, *words: str) -> None:
        for word in words:
            if self.word() != word:
                raise self.error([word])
            self.index += 1

    def match_phrase(self, phrases: Iterable[tuple[str, ...]]) -> tuple[str, ...] | None:
        """Consume and return the longest phrase that comes next, if any."""
        best: tuple[str, ...] | None = None
        for phrase in phrases:
            if self.at(*phrase) and (best is None or len(phrase) > len(best)):
                best = phrase
        if best is not None:
            self.index += len(best)
        return best

    def expect_phrase(self, phrases: Iterable[tuple[str, ...]]) -> tuple[str, ...]:
        phrases = tuple(phrases)
        found = self.match_phrase(phrases)
        if found is None:
            raise self.error(" ".join(phrase) for phrase in phrases)
        return found

    def expect_end(self) -> None:
        # Sentence-final punctuation is optional and may repeat ("?", ".").
        while self.word() in ("?", ".", "!"):
            self.index += 1
        if self.index != len(self.tokens):
            raise self.error(["<end>"])


def _first_words(phrases: Iterable[tuple[str, ...]]) -> list[str]:
    return sorted({phrase[0] for phrase in phrases})


def _object(cursor: _Cursor) -> ObjectRef:
    """object := "the" attribute* (SHAPE | "object" | "thing")"""
    cursor.expect("the")
    found: dict[AttributeKind, str] = {}
    while True:
        word = cursor.word()
        if word in GENERIC_OBJECT_NOUNS:
            cursor.index += 1
            break
        if word is None or word not in ATTRIBUTE_WORDS:
            raise cursor.error(["a colour", "a material", "a shape", "object"])
        kind, value = ATTRIBUTE_WORDS[word]
        if kind in found:
            raise cursor.error([f"one {kind} only (already {found[kind]!r})"])
        found[kind] = value
        cursor.index += 1
        if kind == "shape":  # the shape noun heads the phrase
            break
    return ObjectRef(color=found.get("color"), material=found.get("material"), shape=found.get("shape"))


def _event(cursor: _Cursor) -> EventRef:
    """event := collision-between | pair-collide | subject-event"""
    if cursor.accept("the", "collision", "between"):
        first = _object(cursor)
        cursor.expect("and")
        return EventRef("collision", (first, _object(cursor)))
    subject = _object(cursor)
    if cursor.accept("and"):
        partner = _object(cursor)
        cursor.expect_phrase(PAIR_COLLISION_PHRASES)
        return EventRef("collision", (subject, partner))
    cursor.accept(POSSESSIVE)
    phrase = cursor.match_phrase(SUBJECT_EVENT_PHRASES)
    if phrase is None:
        raise cursor.error(["and", *_first_words(SUBJECT_EVENT_PHRASES)])
    kind = SUBJECT_EVENT_PHRASES[phrase]
    if kind == "collision":
        return EventRef("collision", (subject, _object(cursor)))
    return EventRef(kind, (subject,))


def _wh(cursor: _Cursor) -> None:
    cursor.expect_phrase(WH_PHRASES)


def _condition(cursor: _Cursor) -> ObjectRef:
    """condition := "if" object REMOVAL_PHRASE | "if" ("we" | "you") "remove" object | "without" object"""
    if cursor.accept("without"):
        return _object(cursor)
    cursor.expect("if")
    if cursor.word() in REMOVER_WORDS:
        cursor.index += 1
        cursor.expect("remove")
        return _object(cursor)
    if cursor.word() != "the":
        raise cursor.error(["the", *REMOVER_WORDS])
    removed = _object(cursor)
    cursor.expect_phrase(REMOVAL_PHRASES)
    return removed


def _will_happen(cursor: _Cursor) -> bool:
    """ ("will" | "would") ["not"] "happen" | "happens"; returns whether it is negated."""
    if cursor.accept("happens"):
        return False
    if cursor.word() not in FUTURE_MODALS:
        raise cursor.error([*FUTURE_MODALS, "happens"])
    cursor.index += 1
    negated = cursor.accept("not")
    cursor.expect("happen")
    return negated


def parse_question_ast(text: str) -> QuestionAst:
    """Parse one question into its meaning.

    Raises:
        ParseError: naming the position and word where the text leaves the grammar.
    """
    cursor = _Cursor(text)
    if cursor.word() in ("if", "without"):
        removed = _condition(cursor)
        cursor.accept(",")
        _wh(cursor)
        negated = _will_happen(cursor)
        cursor.expect_end()
        return QuestionAst("counterfactual", negated, removed=removed)
    if cursor.word() not in _first_words(WH_PHRASES):
        raise cursor.error([*_first_words(WH_PHRASES), "if", "without"])
    _wh(cursor)
    if cursor.accept("caused"):
        target = _event(cursor)
        cursor.expect_end()
        return QuestionAst("explanatory", False, target=target)
    if cursor.word() in ("is", "was"):
        cursor.index += 1
        negated = cursor.accept("not")
        cursor.expect("responsible", "for")
        target = _event(cursor)
        cursor.expect_end()
        return QuestionAst("explanatory", negated, target=target)
    if cursor.word() not in (*FUTURE_MODALS, "happens"):
        raise cursor.error(["is", "was", "caused", *FUTURE_MODALS, "happens"])
    negated = _will_happen(cursor)
    if cursor.accept("next"):
        cursor.expect_end()
        return QuestionAst("predictive", negated)
    if cursor.word() not in ("if", "without"):
        raise cursor.error(["next", "if", "without"])
    removed = _condition(cursor)
    cursor.expect_end()
    return QuestionAst("counterfactual", negated, removed=removed)


def parse_choice_ast(text: str) -> EventRef | PresenceRef:
    """Parse one answer choice: an event, or "the presence of <object>".

    Raises:
        ParseError: naming the position and word where the text leaves the grammar.
    """
    cursor = _Cursor(text)
    if cursor.accept("the", "presence", "of"):
        result: EventRef | PresenceRef = PresenceRef(_object(cursor))
    else:
        result = _event(cursor)
    cursor.expect_end()
    return result


__all__ = [
    "EventRef",
    "ObjectRef",
    "ParseError",
    "PresenceRef",
    "QuestionAst",
    "Token",
    "parse_choice_ast",
    "parse_question_ast",
    "tokenize",
]
