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
  (the posterior under a uniform prior), stated in the message. The
  references of a whole question (its program and its choices' programs,
  :func:`ground_question`) are assigned together: one phrase names one
  object throughout the question, and two phrases whose attributes
  contradict ("the gray cube", "the gray cylinder") name two objects;
* ``undecided``: only when the world has no objects.

``absent`` marks a reference that no object matches in a world without any
belief (attributes taken as given, e.g. oracle tracks): the object it names
was never observed, which callers may treat as an object outside the world.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
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


# Branch-and-bound nodes a question's joint assignment may visit before it keeps the best found so far.
MAX_ASSIGNMENT_NODES = 100_000


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
    groundings = _groundings(distinct, objects, likelihood, chosen)
    return [replace(groundings[q], reference=name) for name, q in zip(names, queries)]


def _groundings(distinct: Sequence[AttributeQuery], objects: Sequence[WorldObject], likelihood: np.ndarray,
                chosen: Mapping[int, int]) -> dict[AttributeQuery, Grounding]:
    """The Grounding of each distinct query given its chosen column (likelihood: (Q, N))."""
    ids = [obj.object_id for obj in objects]
    any_belief = any(obj.belief is not None for obj in objects)
    groundings = {}
    for r, query in enumerate(distinct):
        matches = sorted(obj.object_id for obj in objects if obj.matches(query) is True)
        uncertain = sorted(obj.object_id for obj in objects if obj.matches(query) is None)
        total = float(likelihood[r].sum())
        shares = likelihood[r] / total if total > 0 else np.full(len(objects), 1.0 / len(objects))
        order = sorted(range(len(objects)), key=lambda c: (-shares[c], ids[c]))
        status: GroundingStatus = "unique" if len(matches) == 1 and ids[chosen[r]] == matches[0] else "inferred"
        groundings[query] = Grounding(query.phrase(), query, status, (ids[chosen[r]],), tuple(uncertain), tuple(matches),
                                      tuple((ids[c], float(shares[c])) for c in order),
                                      not matches and not uncertain and not any_belief, any_belief)
    return groundings


def contradict(a: AttributeQuery, b: AttributeQuery) -> bool:
    """The two phrases name different values of one attribute ("the gray cube", "the gray cylinder"):
    no object answers both, so under the question's presupposition that each names one object they
    name two."""
    named = dict(a.items())
    return any(kind in named and named[kind] != value for kind, value in b.items())


def ground_question(programs: Sequence[Sequence[str]], objects: Sequence[WorldObject],
                    pinned: Mapping[AttributeQuery, int] | None = None) -> list[list[Grounding]]:
    """Ground the references of one question's programs (its own, then each choice's) together.

    Each phrase "the ..." names exactly one object of the scene (the programs' ``unique``), so within
    the question: one phrase names one object; a phrase whose attributes include all of another's
    ("the brown cube", "the brown object") names the same object as it; phrases that
    :func:`contradict` name distinct objects; within a program distinct phrases name distinct
    objects (as :func:`ground_references`); other phrases of different programs ("the sphere",
    "the cyan object") may or may not name one. An exact unique match keeps its object; the rest
    minimise the summed cost of :func:`_assignment_costs` (branch and bound, exact up to
    MAX_ASSIGNMENT_NODES). ``pinned``: phrases whose object is already decided (object id; e.g. by the
    question's presupposition), kept, with the constraints holding around them. Where no assignment meets
    the constraints (more phrases than objects), each program is grounded on its own, the pinned phrases
    kept. Returns one list of groundings per program, in reference order.
    """
    references = [program_references(p) for p in programs]
    pinned = dict(pinned or {})

    def each_on_its_own() -> list[list[Grounding]]:
        return [[replace(g, object_ids=(pinned[g.query],)) if g.query in pinned and g.object_ids else g
                 for g in ground_references(r, objects)] for r in references]

    if not objects or len(programs) < 2:
        return each_on_its_own()
    distinct = list(dict.fromkeys(q for refs in references for q in refs))
    index = {q: r for r, q in enumerate(distinct)}
    one_program = {(a, b) for refs in references for a in {index[q] for q in refs} for b in {index[q] for q in refs} if a != b}
    groups = _same_object_groups(distinct, one_program)
    group_of = {r: g for g, rows in enumerate(groups) for r in rows}
    named = [AttributeQuery(**{kind: value for r in rows for kind, value in distinct[r].items()}) for rows in groups]
    differ = {(group_of[a], group_of[b]) for a in range(len(distinct)) for b in range(len(distinct))
              if (a, b) in one_program or contradict(distinct[a], distinct[b])}
    likelihood, costs = _assignment_costs(named, objects)
    fixed: dict[int, int] = {}
    for g, query in enumerate(named):
        matches = [c for c, obj in enumerate(objects) if obj.matches(query) is True]
        if len(matches) == 1:
            fixed[g] = matches[0]
    columns = {obj.object_id: c for c, obj in enumerate(objects)}
    pins = {(group_of[index[q]], columns[i]) for q, i in pinned.items() if q in index and i in columns}
    if len({g for g, _ in pins}) < len(pins):  # one object's phrases pinned to two objects
        return each_on_its_own()
    fixed.update(pins)
    assigned = _constrained_assignment(costs, fixed, differ)
    if assigned is None:
        return each_on_its_own()
    if named != distinct:  # merged phrases: each keeps the shares of its own attributes
        likelihood, _ = _assignment_costs(distinct, objects)
    groundings = _groundings(distinct, objects, likelihood, {r: assigned[group_of[r]] for r in range(len(distinct))})
    return [[groundings[q] for q in refs] for refs in references]


def _same_object_groups(queries: Sequence[AttributeQuery], one_program: set[tuple[int, int]]) -> list[list[int]]:
    """Rows that name one object: a query whose attributes include all of another's, joined (union-find),
    unless the two are phrases of one program. A group whose members contradict each other or share a
    program (no object answers it) falls back to single rows."""
    parent = list(range(len(queries)))

    def root(r: int) -> int:
        while parent[r] != r:
            r = parent[r]
        return r

    for a, general in enumerate(queries):
        for b, specific in enumerate(queries):
            if a != b and (a, b) not in one_program and set(general.items()) < set(specific.items()):
                parent[root(a)] = root(b)
    groups: dict[int, list[int]] = {}
    for r in range(len(queries)):
        groups.setdefault(root(r), []).append(r)
    result = []
    for rows in groups.values():
        consistent = not any((a, b) in one_program or contradict(queries[a], queries[b]) for a in rows for b in rows if a != b)
        result.extend([rows] if consistent else [[r] for r in rows])
    return result


def _constrained_assignment(costs: np.ndarray, fixed: Mapping[int, int], differ: set[tuple[int, int]]) -> dict[int, int] | None:
    """Rows -> columns minimising the summed (Q, N) ``costs``, rows in ``fixed`` kept, each (a, b) in
    ``differ`` on distinct columns; None when no assignment meets them (or fixed rows break them)."""
    if any((a, b) in differ and fixed[a] == fixed[b] for a in fixed for b in fixed if a != b):
        return None
    free = sorted((r for r in range(costs.shape[0]) if r not in fixed), key=lambda r: float(costs[r].min()))
    candidates = {r: [int(c) for c in np.argsort(costs[r], kind="stable")] for r in free}
    floor = np.concatenate([np.cumsum([float(costs[r].min()) for r in free][::-1])[::-1], [0.0]])
    best: dict[str, Any] = {"cost": math.inf, "chosen": None}
    nodes = 0
    chosen = dict(fixed)

    def visit(k: int, total: float) -> None:
        nonlocal nodes
        nodes += 1
        if k == len(free):
            best["cost"], best["chosen"] = total, dict(chosen)
            return
        row = free[k]
        for column in candidates[row]:
            cost = total + float(costs[row, column])
            if cost + floor[k + 1] >= best["cost"] or nodes > MAX_ASSIGNMENT_NODES:
                break  # candidates are in cost order: none after this one can do better
            if any(chosen.get(other) == column for other in range(costs.shape[0]) if (row, other) in differ):
                continue
            chosen[row] = column
            visit(k + 1, cost)
            del chosen[row]

    visit(0, 0.0)
    return best["chosen"]


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
