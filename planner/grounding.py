"""Reference grounding: attribute phrases -> world object ids.

The world's objects come from the ``get_world_summary`` tool (ids and the
colour / material / shape the world carries). A reference ("the rubber
cube", "the green object", or the ``objects <v> filter_* ... unique`` part of
a program) is grounded by attribute match:

* ``unique``: exactly one object matches -> its id;
* ``ambiguous``: several match -> all their ids, never one picked silently;
* ``unmatched``: none matches.

An object whose world record lacks an attribute the phrase names (a
perceived world may leave a colour unknown) neither matches nor is ruled
out: it is listed in ``uncertain`` so the report can say so.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Iterable, Literal, Mapping, Sequence

from planner.grammar import ParseError, tokenize
from planner.vocabulary import ATTRIBUTE_WORDS, FILTER_ORDER, GENERIC_OBJECT_NOUNS, OP_OBJECTS, OP_UNIQUE

GroundingStatus = Literal["unique", "ambiguous", "unmatched"]
_FILTER_KIND = {operator: kind for kind, operator in FILTER_ORDER}


@dataclass(frozen=True)
class AttributeQuery:
    """What a reference asks for; None means "any"."""

    color: str | None = None
    material: str | None = None
    shape: str | None = None

    def items(self) -> tuple[tuple[str, str], ...]:
        return tuple((k, v) for k, v in (("color", self.color), ("material", self.material), ("shape", self.shape)) if v is not None)

    def phrase(self) -> str:
        words = [v for _, v in self.items() if _ != "shape"]
        return "the " + " ".join(words + [self.shape or "object"])


@dataclass(frozen=True)
class WorldObject:
    """One object of the world summary: id and the attributes the world knows (None = unknown)."""

    object_id: int
    color: str | None
    material: str | None
    shape: str | None

    def describe(self) -> str:
        return f"object {self.object_id} ({' '.join(v or '?' for v in (self.color, self.material, self.shape))})"


@dataclass(frozen=True)
class Grounding:
    """The result of grounding one reference.

    object_ids: the matching ids (one when unique). uncertain: ids whose
    record lacks an attribute the reference names.
    """

    reference: str
    query: AttributeQuery
    status: GroundingStatus
    object_ids: tuple[int, ...]
    uncertain: tuple[int, ...] = ()

    @property
    def object_id(self) -> int:
        if self.status != "unique":
            raise ValueError(f"{self.reference!r} is {self.status}: {self.message()}")
        return self.object_ids[0]

    def message(self) -> str:
        if self.status == "unique":
            text = f"{self.reference} -> object {self.object_ids[0]}"
        elif self.status == "ambiguous":
            text = f"{self.reference} is ambiguous: objects {list(self.object_ids)} all match"
        else:
            text = f"{self.reference} matches no object of the world"
        if self.uncertain:
            text += f" (objects {list(self.uncertain)} have an unknown attribute and were not counted)"
        return text

    def to_dict(self) -> dict[str, Any]:
        return {"reference": self.reference, "attributes": dict(self.query.items()), "status": self.status,
                "object_ids": list(self.object_ids), "uncertain": list(self.uncertain), "message": self.message()}


def objects_from_summary(summary: Mapping[str, Any]) -> tuple[WorldObject, ...]:
    """The objects of a ``get_world_summary`` result.

    Raises:
        ValueError: the summary has no ``objects`` list or an entry lacks ``object_id``.
    """
    entries = summary.get("objects")
    if not isinstance(entries, list):
        raise ValueError("world summary: 'objects' must be a list")
    objects = []
    for k, entry in enumerate(entries):
        if not isinstance(entry, Mapping) or not isinstance(entry.get("object_id"), int):
            raise ValueError(f"world summary: objects[{k}].object_id must be an integer")
        objects.append(WorldObject(entry["object_id"], entry.get("color"), entry.get("material"), entry.get("shape")))
    return tuple(objects)


def parse_object_phrase(text: str) -> AttributeQuery:
    """"the rubber cube" / "the green object" / "red sphere" -> AttributeQuery.

    Raises:
        ValueError: a word that is neither an attribute nor a generic noun, or
            two values of one attribute.
    """
    found: dict[str, str] = {}
    try:
        tokens = tokenize(text)
    except ParseError as error:
        raise ValueError(str(error)) from None
    words = [t.text for t in tokens if t.text not in ("?", ",", ".")]
    if words and words[0] in ("the", "a", "an"):
        words = words[1:]
    if not words:
        raise ValueError(f"object phrase {text!r}: no attribute or noun")
    for word in words:
        if word in GENERIC_OBJECT_NOUNS:
            continue
        if word not in ATTRIBUTE_WORDS:
            raise ValueError(f"object phrase {text!r}: unknown word {word!r} (expected a colour, material, shape, 'object')")
        kind, value = ATTRIBUTE_WORDS[word]
        if kind in found and found[kind] != value:
            raise ValueError(f"object phrase {text!r}: two values for {kind} ({found[kind]!r}, {value!r})")
        found[kind] = value
    return AttributeQuery(**found)


def ground(query: AttributeQuery, objects: Sequence[WorldObject], reference: str | None = None) -> Grounding:
    """Match a query against the world's objects; never picks among several."""
    matches, uncertain = [], []
    for obj in objects:
        verdicts = [getattr(obj, kind) == value if getattr(obj, kind) is not None else None for kind, value in query.items()]
        if all(v is True for v in verdicts):
            matches.append(obj.object_id)
        elif None in verdicts and False not in verdicts:
            uncertain.append(obj.object_id)
    status: GroundingStatus = "unique" if len(matches) == 1 else ("ambiguous" if matches else "unmatched")
    return Grounding(reference or query.phrase(), query, status, tuple(sorted(matches)), tuple(sorted(uncertain)))


def ground_phrase(text: str, objects: Sequence[WorldObject]) -> Grounding:
    return ground(parse_object_phrase(text), objects, reference=text)


def program_references(program: Sequence[str]) -> list[AttributeQuery]:
    """The object references of a program: each ``objects (value filter_*)* unique`` run, in order."""
    references = []
    k = 0
    while k < len(program):
        if program[k] != OP_OBJECTS:
            k += 1
            continue
        j, found = k + 1, {}
        while j + 1 < len(program) and program[j + 1] in _FILTER_KIND:
            found[_FILTER_KIND[program[j + 1]]] = program[j]
            j += 2
        if j < len(program) and program[j] == OP_UNIQUE:
            references.append(AttributeQuery(**found))
        k = j + 1 if j > k + 1 else k + 1
    return references


def ground_program(program: Sequence[str], objects: Sequence[WorldObject]) -> list[Grounding]:
    """Ground every object reference of a program (see :func:`program_references`)."""
    return [ground(query, objects) for query in program_references(program)]


def failed(groundings: Iterable[Grounding]) -> list[Grounding]:
    return [g for g in groundings if g.status != "unique"]
