"""Reference grounding: attribute phrases -> world object ids, always decided when the world has objects.

The world's objects come from the ``get_world_summary`` tool (ids, the
colour / material / shape the world carries and, for a world perceived from
video, ``attribute_belief``: a probability per value and the frames the
object was seen in). A reference ("the rubber cube", "the green object", or
the ``objects <v> filter_* ... unique`` part of a program) is grounded:

* ``unique``: exactly one object's stated attributes match -> its id (as the
  interpreter would filter);
* ``inferred``: none or several match -> the object with the highest
  likelihood of the phrase's attributes: the product of the belief's
  probabilities of the named values, or for an object without a belief 1 per
  matching attribute, MISMATCH_LIKELIHOOD per differing one and 1/|values| per
  unknown one. The references of one program are assigned jointly to
  distinct objects (Hungarian on -log likelihood); between near-equal
  likelihoods the object seen in more frames wins (a duplicate track is
  short). ``probabilities`` gives each object's share of the likelihood
  (the posterior under a uniform prior), stated in the message;
* ``undecided``: only when the world has no objects.

``absent`` marks a reference that no object matches in a world without any
belief (attributes taken as given, e.g. oracle tracks): the object it names
was never observed, which callers may treat as an object outside the world.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Literal, Mapping, Sequence

import numpy as np
from scipy.optimize import linear_sum_assignment

from planner.grammar import ParseError, tokenize
from planner.program import ATTRIBUTE_FILTERS, COLORS, MATERIALS, SHAPES, reference_spans
from planner.vocabulary import ATTRIBUTE_WORDS, GENERIC_OBJECT_NOUNS

GroundingStatus = Literal["unique", "inferred", "undecided"]
ATTRIBUTE_NAMES: tuple[str, ...] = ("color", "material", "shape")
# Value counts per attribute (an unknown attribute of an object without a belief: 1 / count).
VALUE_COUNTS: Mapping[str, int] = {"color": len(COLORS), "material": len(MATERIALS), "shape": len(SHAPES)}
MISMATCH_LIKELIHOOD = 1e-3  # an object without a belief whose stated attribute differs from the phrase's
MIN_LIKELIHOOD = 1e-12  # floor of a belief's probability (keeps every likelihood > 0, so -log is finite)
# Tie-break by track support: each e-fold of frames seen is worth this many nats of likelihood,
# so it decides only between near-equal likelihoods (10x the frames: a factor 1.12).
SUPPORT_NATS = 0.05
ID_TIE_NATS = 1e-9  # last resort between exactly equal candidates: the lower id


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
    """One object of the world summary: id, the attributes the world states (None = unknown) and,
    for a perceived world, belief: attribute -> value -> probability, support_frames: frames seen."""

    object_id: int
    color: str | None
    material: str | None
    shape: str | None
    belief: Mapping[str, Mapping[str, float]] | None = field(default=None, hash=False)
    support_frames: int = 0

    def describe(self) -> str:
        return f"object {self.object_id} ({' '.join(v or '?' for v in (self.color, self.material, self.shape))})"

    def matches(self, query: AttributeQuery) -> bool | None:
        """True: every named attribute is stated and equal; False: one differs; None: otherwise (an unknown one)."""
        verdicts = [getattr(self, kind) == value if getattr(self, kind) is not None else None for kind, value in query.items()]
        if False in verdicts:
            return False
        return None if None in verdicts else True

    def likelihood(self, query: AttributeQuery) -> float:
        """P(the phrase's attribute values | this object) (module docstring)."""
        value = 1.0
        for kind, wanted in query.items():
            if self.belief is not None and kind in self.belief:
                value *= max(float(self.belief[kind].get(wanted, 0.0)), MIN_LIKELIHOOD)
            elif getattr(self, kind) is None:
                value /= VALUE_COUNTS[kind]
            elif getattr(self, kind) != wanted:
                value *= MISMATCH_LIKELIHOOD
        return value


@dataclass(frozen=True)
class Grounding:
    """The result of grounding one reference.

    object_ids: the chosen object (one id) unless undecided. matches: objects
    whose stated attributes match exactly. uncertain: objects with an unknown
    attribute the reference names. probabilities: (object id, share of the
    likelihood), most probable first. absent: no object matches in a world
    without beliefs (module docstring).
    """

    reference: str
    query: AttributeQuery
    status: GroundingStatus
    object_ids: tuple[int, ...]
    uncertain: tuple[int, ...] = ()
    matches: tuple[int, ...] = ()
    probabilities: tuple[tuple[int, float], ...] = ()
    absent: bool = False
    believed: bool = False  # the world carries attribute beliefs (a perceived world)

    @property
    def object_id(self) -> int:
        if self.status == "undecided":
            raise ValueError(f"{self.reference!r} is undecided: {self.message()}")
        return self.object_ids[0]

    @property
    def probability(self) -> float | None:
        """The chosen object's share of the likelihood (None when undecided)."""
        return dict(self.probabilities).get(self.object_ids[0]) if self.object_ids else None

    def message(self) -> str:
        if self.status == "undecided":
            return f"{self.reference}: the world has no objects, nothing to ground it to"
        if self.status == "unique" and not self.uncertain:
            return f"{self.reference} -> object {self.object_ids[0]}"
        chosen = self.object_ids[0]
        others = [(i, p) for i, p in self.probabilities if i != chosen]
        odds = f"p={self.probability:.2f}" + (f"; next object {others[0][0]}, p={others[0][1]:.2f}" if others else "")
        text = f"'{self.reference}' -> object {chosen} ({odds})"
        if self.absent:
            text = f"{self.reference} matches no object of the world (closest: object {chosen}, {odds})"
        elif self.status == "inferred":
            reason = (f"objects {list(self.matches)} all match its stated attributes" if len(self.matches) > 1
                      else f"object {self.matches[0]} matches its stated attributes but is taken by another reference" if self.matches
                      else "no object's stated attributes match it")
            how = "the perceived attribute probabilities" if self.probabilities and self.believed else "attribute likelihood"
            text += f": {reason}; chosen by {how} (near ties: more frames seen, then the lower id)"
        if self.uncertain:
            text += f" (objects {list(self.uncertain)} have an unknown attribute)"
        return text

    def to_dict(self) -> dict[str, Any]:
        return {"reference": self.reference, "attributes": dict(self.query.items()), "status": self.status,
                "object_ids": list(self.object_ids), "uncertain": list(self.uncertain), "matches": list(self.matches),
                "probabilities": [[i, round(p, 4)] for i, p in self.probabilities], "absent": self.absent,
                "believed": self.believed, "message": self.message()}


def objects_from_summary(summary: Mapping[str, Any]) -> tuple[WorldObject, ...]:
    """The objects of a ``get_world_summary`` result (with their ``attribute_belief`` when present).

    Raises:
        ValueError: the summary has no ``objects`` list, an entry lacks ``object_id``, or a belief is malformed.
    """
    entries = summary.get("objects")
    if not isinstance(entries, list):
        raise ValueError("world summary: 'objects' must be a list")
    objects = []
    for k, entry in enumerate(entries):
        if not isinstance(entry, Mapping) or not isinstance(entry.get("object_id"), int):
            raise ValueError(f"world summary: objects[{k}].object_id must be an integer")
        belief, support = None, 0
        document = entry.get("attribute_belief")
        if document is not None:
            if not isinstance(document, Mapping) or not all(isinstance(document.get(name), Mapping) for name in ATTRIBUTE_NAMES):
                raise ValueError(f"world summary: objects[{k}].attribute_belief must map color, material and shape to probabilities")
            belief = {name: {str(v): float(p) for v, p in document[name].items()} for name in ATTRIBUTE_NAMES}
            support = int(document.get("support_frames", 0))
        objects.append(WorldObject(entry["object_id"], entry.get("color"), entry.get("material"), entry.get("shape"), belief, support))
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


def _assignment_costs(queries: Sequence[AttributeQuery], objects: Sequence[WorldObject]) -> tuple[np.ndarray, np.ndarray]:
    """((Q, N) likelihoods, (Q, N) costs: -log likelihood, less the support bonus and the id tie-break)."""
    likelihood = np.array([[obj.likelihood(q) for obj in objects] for q in queries], dtype=float).reshape(len(queries), len(objects))
    bonus = np.array([SUPPORT_NATS * math.log1p(max(obj.support_frames, 0)) - ID_TIE_NATS * k for k, obj in enumerate(objects)])
    return likelihood, -np.log(likelihood) - bonus[None, :]


def ground_references(queries: Sequence[AttributeQuery], objects: Sequence[WorldObject],
                      references: Sequence[str] | None = None) -> list[Grounding]:
    """Ground the references of one program together (module docstring).

    An exact unique match keeps its object; the other references are assigned
    to distinct objects not taken by those (all objects when too few remain),
    minimising the summed -log likelihood. Equal queries share one object.
    """
    names = list(references) if references is not None else [q.phrase() for q in queries]
    if not objects:
        return [Grounding(name, q, "undecided", ()) for name, q in zip(names, queries)]
    distinct = list(dict.fromkeys(queries))
    likelihood, costs = _assignment_costs(distinct, objects)
    ids = [obj.object_id for obj in objects]
    matches = [[obj.object_id for obj in objects if obj.matches(q) is True] for q in distinct]
    uncertain = [[obj.object_id for obj in objects if obj.matches(q) is None] for q in distinct]
    chosen: dict[int, int] = {r: ids.index(m[0]) for r, m in enumerate(matches) if len(m) == 1}
    free = [r for r in range(len(distinct)) if r not in chosen]
    if free:
        columns = [c for c in range(len(objects)) if c not in set(chosen.values())]
        if len(columns) < len(free):
            columns = list(range(len(objects)))  # more references than objects left: distinctness cannot hold
        rows, cols = linear_sum_assignment(costs[np.ix_(free, columns)])
        chosen.update({free[r]: columns[c] for r, c in zip(rows, cols)})
        for r in free:  # references beyond the number of objects: each its own best
            chosen.setdefault(r, int(np.argmin(costs[r])))
    any_belief = any(obj.belief is not None for obj in objects)
    groundings = {}
    for r, query in enumerate(distinct):
        total = float(likelihood[r].sum())
        shares = likelihood[r] / total if total > 0 else np.full(len(objects), 1.0 / len(objects))
        order = sorted(range(len(objects)), key=lambda c: (-shares[c], ids[c]))
        status: GroundingStatus = "unique" if len(matches[r]) == 1 and ids[chosen[r]] == matches[r][0] else "inferred"
        groundings[query] = (status, (ids[chosen[r]],), tuple(sorted(uncertain[r])), tuple(sorted(matches[r])),
                             tuple((ids[c], float(shares[c])) for c in order), not matches[r] and not uncertain[r] and not any_belief,
                             any_belief)
    return [Grounding(name, q, *groundings[q]) for name, q in zip(names, queries)]


def ground(query: AttributeQuery, objects: Sequence[WorldObject], reference: str | None = None) -> Grounding:
    """Ground one reference on its own (see :func:`ground_references`)."""
    return ground_references([query], objects, None if reference is None else [reference])[0]


def ground_phrase(text: str, objects: Sequence[WorldObject]) -> Grounding:
    return ground(parse_object_phrase(text), objects, reference=text)


def program_references(program: Sequence[str]) -> list[AttributeQuery]:
    """The object references of a program (planner.program.reference_spans), in order."""
    references = []
    for start, end in reference_spans(program):
        found = {ATTRIBUTE_FILTERS[program[k + 1]]: program[k] for k in range(start + 1, end, 2)}
        references.append(AttributeQuery(**found))
    return references


def ground_program(program: Sequence[str], objects: Sequence[WorldObject]) -> list[Grounding]:
    """Ground every object reference of a program jointly (see :func:`ground_references`)."""
    return ground_references(program_references(program), objects)


def bound_ids(groundings: Sequence[Grounding]) -> list[int] | None:
    """The chosen id of each reference, for planner.program.execute(bound=...); None if one is undecided."""
    if any(g.status == "undecided" for g in groundings):
        return None
    return [g.object_id for g in groundings]


def failed(groundings: Sequence[Grounding]) -> list[Grounding]:
    """References not decided (the world has no objects)."""
    return [g for g in groundings if g.status == "undecided"]
