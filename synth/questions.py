"""CLEVRER-style multiple-choice questions with programs, answered by running them.

Phrasing and program style follow CLEVRER's released questions (see the 564
real explanatory questions in ../shared/clevrer): objects are named by an
attribute combination that is unique in the video, programs filter colour,
then material, then shape. Two phrasings (``PHRASINGS``): "shortest" names
an object by its shortest such combination ("the sphere", "the metal cube",
"the yellow rubber cylinder"); "clevrer" draws, at every mention, one of its
unique combinations with CLEVRER's frequencies of combination kinds
(``CLEVRER_REFERENCE_WEIGHTS``), so one question may name an object twice in
two ways ("the brown cube's colliding with ...", "... the brown object"), as
CLEVRER's questions do. Every answer is computed by executing
``choice.program + question.program`` with planner.program on the scene's
MuJoCo events, never set by hand.

Programs (A, B: object sub-programs ``objects <attr> filter_<attr> ... unique``):

* explanatory: ``events <event E> filter_ancestor belong_to [negate]`` with
  E = ``events A filter_collision B filter_collision unique`` or
  ``events A filter_out unique``; choices are objects (``A``) or events
  (collision as above, ``events A filter_in unique``).
* predictive: ``unseen_events belong_to``; choices
  ``all_events A filter_collision B filter_collision unique``.
* counterfactual: ``A counterfact_events belong_to [negate]``; choices as predictive.

No question or option names an object never seen in the video (``seen``:
objects that entered late, after the video, or never came into view stay
out of every question; they still take part in the physics).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np

from planner.program import EventRecord, ObjectRecord, ProgramScene, causal_ancestors, execute, score_choice

# How many options are correct in CLEVRER's explanatory questions (0..4
# correct of 4; counts from the shared 564-question subset), used to balance.
CORRECT_COUNT_WEIGHTS = np.array([41, 124, 221, 146, 32], dtype=float)
MAX_EXPLANATORY = 3
MAX_PREDICTIVE = 2
MAX_COUNTERFACTUAL = 3

ATTRIBUTE_ORDER = ("color", "material", "shape")
PHRASINGS = ("shortest", "clevrer")
# How often CLEVRER names an object by each attribute combination: the filters of the 4,063 object
# references in the programs of the 564 real questions in ../shared/clevrer (docs/formats.md).
CLEVRER_REFERENCE_WEIGHTS: dict[tuple[str, ...], int] = {
    ("color", "shape"): 1349, ("color",): 776, ("shape",): 737, ("material", "shape"): 556,
    ("color", "material", "shape"): 331, ("color", "material"): 263, ("material",): 51,
}


@dataclass(frozen=True)
class Reference:
    """How to name one object: its phrase (without the article) and its program."""

    phrase: str
    program: tuple[str, ...]


def check_phrasing(phrasing: str, name: str = "phrasing") -> None:
    """ValueError naming ``name`` unless ``phrasing`` is one of PHRASINGS."""
    if phrasing not in PHRASINGS:
        raise ValueError(f"{name}: expected one of {', '.join(PHRASINGS)}, got {phrasing!r}")


def _reference(obj: ObjectRecord, subset: tuple[str, ...]) -> Reference:
    """The phrase and program naming ``obj`` by the attributes of ``subset`` (in ATTRIBUTE_ORDER)."""
    words = [getattr(obj, a) for a in subset if a != "shape"]
    words.append(obj.shape if "shape" in subset else "object")
    program = ["objects"]
    for a in subset:
        program += [getattr(obj, a), f"filter_{a}"]
    program.append("unique")
    return Reference(" ".join(words), tuple(program))


def _unique_subsets(obj: ObjectRecord, objects: tuple[ObjectRecord, ...]) -> list[tuple[str, ...]]:
    """Every non-empty attribute subset that singles ``obj`` out among ``objects``, shortest first."""
    return [subset for size in (1, 2, 3) for subset in itertools.combinations(ATTRIBUTE_ORDER, size)
            if sum(all(getattr(o, a) == getattr(obj, a) for a in subset) for o in objects) == 1]


def object_references(objects: tuple[ObjectRecord, ...]) -> dict[int, list[Reference]]:
    """All shortest unique attribute references of each object.

    The shortest non-empty attribute subset(s) that single the object out
    among all objects of the video; ties are all returned (the caller picks).
    """
    references: dict[int, list[Reference]] = {}
    for obj in objects:
        subsets = _unique_subsets(obj, objects)
        if subsets:
            references[obj.id] = [_reference(obj, s) for s in subsets if len(s) == len(subsets[0])]
    return references


def clevrer_references(objects: tuple[ObjectRecord, ...]) -> dict[int, list[tuple[Reference, float]]]:
    """Each object's unique attribute references with CLEVRER's weight of their kind (CLEVRER_REFERENCE_WEIGHTS)."""
    return {obj.id: [(_reference(obj, s), float(CLEVRER_REFERENCE_WEIGHTS[s])) for s in subsets]
            for obj in objects if (subsets := _unique_subsets(obj, objects))}


class _Namer:
    """Names objects at each mention, by the phrasing (PHRASINGS)."""

    def __init__(self, scene: ProgramScene, rng: np.random.Generator, phrasing: str = "shortest"):
        check_phrasing(phrasing)
        if phrasing == "shortest":
            self.references = {k: [(r, 1.0) for r in refs] for k, refs in object_references(scene.objects).items()}
        else:
            self.references = clevrer_references(scene.objects)
        self.phrasing = phrasing
        self.rng = rng

    def __call__(self, object_id: int) -> Reference:
        options = self.references[object_id]
        if self.phrasing == "shortest":
            return options[int(self.rng.integers(len(options)))][0]  # synth-1's draw: datasets of a seed stay the same
        weights = np.array([w for _, w in options])
        return options[int(self.rng.choice(len(options), p=weights / weights.sum()))][0]


def _collision_program(a: Reference, b: Reference, source: str = "events") -> list[str]:
    return [source, *a.program, "filter_collision", *b.program, "filter_collision", "unique"]


def _runs(program: list[str], scene: ProgramScene) -> bool:
    try:
        execute(program, scene)
        return True
    except ValueError:
        return False


def _choose_balanced(rng: np.random.Generator, correct: list, wrong: list, total: int, weights: np.ndarray | None = None) -> list[tuple[object, bool]]:
    """Pick ``total`` options mixing correct and wrong ones, CLEVRER-like counts of correct ones."""
    total = min(total, len(correct) + len(wrong))
    feasible = [k for k in range(total + 1) if k <= len(correct) and total - k <= len(wrong)]
    if not feasible:
        return []
    weights = _count_weights(total, weights)
    w = np.array([weights[k] if k < len(weights) else 0.0 for k in feasible], dtype=float)
    if w.sum() <= 0:
        w = np.ones(len(feasible))
    k = feasible[int(rng.choice(len(feasible), p=w / w.sum()))]
    picked = [(correct[i], True) for i in rng.permutation(len(correct))[:k]]
    picked += [(wrong[i], False) for i in rng.permutation(len(wrong))[: total - k]]
    order = rng.permutation(len(picked))
    return [picked[i] for i in order]


def _finish(question: dict, picked: list[tuple[dict, bool]], scene: ProgramScene) -> dict | None:
    if not picked:
        return None
    choices = []
    for k, (choice, _) in enumerate(picked):
        answer = "correct" if score_choice(question["program"], choice["program"], scene) else "wrong"
        choices.append({"choice_id": k, "choice": choice["choice"], "program": choice["program"], "answer": answer})
    question["choices"] = choices
    return question


def _seen_ids(scene: ProgramScene, seen: frozenset[int] | None) -> frozenset[int]:
    """Objects a question may name: ``seen``, or every object when None."""
    return frozenset(o.id for o in scene.objects) if seen is None else frozenset(seen)


def explanatory_questions(scene: ProgramScene, rng: np.random.Generator, seen: frozenset[int] | None = None,
                          phrasing: str = "shortest") -> list[dict]:
    name = _Namer(scene, rng, phrasing)
    visible = _seen_ids(scene, seen)
    observed = [e for e in scene.events if e.frame is not None and e.frame < scene.observed_frames and set(e.objects) <= visible]
    collisions = [e for e in observed if e.kind == "collision"]
    targets = [e for e in observed if e.kind in ("collision", "out")]
    rng.shuffle(targets)
    # Causally richer targets first: events that have ancestors.
    targets.sort(key=lambda e: -_ancestor_count(scene, e))
    questions = []
    for target in targets:
        if len(questions) >= MAX_EXPLANATORY:
            break
        if target.kind == "collision":
            a, b = (name(i) for i in rng.permutation(target.objects))
            event_program = _collision_program(a, b)
            long_form = bool(rng.integers(2))
            subject = f"the collision between the {a.phrase} and the {b.phrase}" if long_form else f"the {a.phrase}'s colliding with the {b.phrase}"
        else:
            a = name(target.objects[0])
            event_program = ["events", *a.program, "filter_out", "unique"]
            subject = f"the {a.phrase}'s exit" if rng.integers(2) else f"the {a.phrase}'s exiting the scene"
        if not _runs(event_program, scene):
            continue  # the pair collides more than once: no unique reference
        positive = ["events", *event_program, "filter_ancestor", "belong_to"]
        candidates = []
        for obj in scene.objects:
            if obj.id in target.objects or obj.id not in visible:
                continue
            ref = name(obj.id)
            candidates.append({"choice": f"the presence of the {ref.phrase}", "program": list(ref.program)})
        for event in collisions:
            if event == target:
                continue
            x, y = (name(i) for i in rng.permutation(event.objects))
            text_choice = f"the collision between the {x.phrase} and the {y.phrase}" if rng.integers(2) else f"the {x.phrase}'s colliding with the {y.phrase}"
            candidates.append({"choice": text_choice, "program": _collision_program(x, y)})
        for event in observed:
            if event.kind == "in":
                x = name(event.objects[0])
                text_choice = f"the {x.phrase}'s entrance" if rng.integers(2) else f"the {x.phrase}'s entering the scene"
                candidates.append({"choice": text_choice, "program": ["events", *x.program, "filter_in", "unique"]})
        candidates = [c for c in candidates if _runs(c["program"], scene)]
        yes = [c for c in candidates if score_choice(positive, c["program"], scene)]
        no = [c for c in candidates if not score_choice(positive, c["program"], scene)]
        negated = _negate_for_balance(rng, len(yes), len(no), 4, CORRECT_COUNT_WEIGHTS)
        correct, wrong = (no, yes) if negated else (yes, no)
        program = positive + (["negate"] if negated else [])
        lead = "Which of the following is not responsible for" if negated else "Which of the following is responsible for"
        text = f"{lead} {subject}?"
        picked = _choose_balanced(rng, correct, wrong, 4, CORRECT_COUNT_WEIGHTS)
        question = _finish({"question_type": "explanatory", "question": text, "program": program}, picked, scene)
        if question is not None and len(question["choices"]) >= 2:
            questions.append(question)
    return questions


def _count_weights(total: int, weights: np.ndarray | None) -> np.ndarray:
    if weights is None or len(weights) != total + 1:
        # Fewer options than CLEVRER's 4: symmetric binomial counts of correct ones.
        return np.array([math.comb(total, k) for k in range(total + 1)], dtype=float)
    return np.asarray(weights, dtype=float)


def _expected_share(correct: int, wrong: int, total: int, weights: np.ndarray | None) -> float:
    """Expected share of correct options that _choose_balanced will give."""
    total = min(total, correct + wrong)
    w = _count_weights(total, weights)
    feasible = [k for k in range(total + 1) if k <= correct and total - k <= wrong]
    mass = sum(w[k] for k in feasible)
    if not feasible or total == 0:
        return 0.5
    if mass <= 0:
        return float(np.mean(feasible)) / total
    return sum(w[k] * k for k in feasible) / mass / total


def _negate_for_balance(rng: np.random.Generator, yes: int, no: int, total: int = 4, weights: np.ndarray | None = None) -> bool:
    """Pick the positive or the negated form ("not responsible", "will not happen").

    When both forms can give about half correct options, either is taken at
    random; otherwise the one closer to half, so that over a dataset about
    half of all options are correct while both forms occur.
    """
    positive = abs(_expected_share(yes, no, total, weights) - 0.5)
    negative = abs(_expected_share(no, yes, total, weights) - 0.5)
    if abs(positive - negative) < 0.1:
        return bool(rng.integers(2))
    return negative < positive


def _ancestor_count(scene: ProgramScene, event: EventRecord) -> int:
    return len(causal_ancestors(scene, event))


def _pair_choice(name: _Namer, rng: np.random.Generator, pair: tuple[int, int]) -> dict:
    a, b = (name(i) for i in rng.permutation(pair))
    return {"choice": f"The {a.phrase} collides with the {b.phrase}", "program": _collision_program(a, b, "all_events")}


def predictive_questions(scene: ProgramScene, rng: np.random.Generator, seen: frozenset[int] | None = None,
                         phrasing: str = "shortest") -> list[dict]:
    name = _Namer(scene, rng, phrasing)
    program = ["unseen_events", "belong_to"]
    ids = sorted(_seen_ids(scene, seen))
    all_pairs = list(itertools.combinations(ids, 2))
    future_pairs = sorted(
        {e.objects for e in scene.events if e.kind == "collision" and e.frame is not None and e.frame >= scene.observed_frames and set(e.objects) <= set(ids)}
    )
    other_pairs = [p for p in all_pairs if p not in future_pairs]
    questions = []
    for pair in [future_pairs[i] for i in rng.permutation(len(future_pairs))][:MAX_PREDICTIVE]:
        if not other_pairs:
            break
        # A plausible wrong option: preferably one sharing an object with the true one.
        related = [p for p in other_pairs if set(p) & set(pair)]
        pool = related if related and rng.uniform() < 0.6 else other_pairs
        wrong = pool[int(rng.integers(len(pool)))]
        picked = [(_pair_choice(name, rng, pair), True), (_pair_choice(name, rng, wrong), False)]
        picked = [picked[i] for i in rng.permutation(2)]
        question = _finish({"question_type": "predictive", "question": "Which event will happen next?", "program": program}, picked, scene)
        if question is not None:
            questions.append(question)
    return questions


def counterfactual_questions(scene: ProgramScene, rng: np.random.Generator, seen: frozenset[int] | None = None,
                             phrasing: str = "shortest") -> list[dict]:
    if scene.counterfactual is None:
        return []
    name = _Namer(scene, rng, phrasing)
    ids = sorted(_seen_ids(scene, seen))
    observed_collisions = [e for e in scene.events if e.kind == "collision" and e.frame is not None and e.frame < scene.observed_frames]
    involved = sorted({i for e in observed_collisions for i in e.objects} & set(ids))
    questions = []
    for removed in [involved[i] for i in rng.permutation(len(involved))][:MAX_COUNTERFACTUAL]:
        ref = name(removed)
        remaining = [i for i in ids if i != removed]
        pairs = list(itertools.combinations(remaining, 2))
        factual = {e.objects for e in observed_collisions}
        counterfactual = {e.objects for e in scene.counterfactual(removed) if e.kind == "collision" and e.frame is not None and e.frame < scene.observed_frames}
        interesting = [p for p in pairs if p in factual or p in counterfactual]
        others = [p for p in pairs if p not in interesting]
        # Mostly pairs that collide in one of the two worlds, plus a random one.
        pool = interesting + [others[i] for i in rng.permutation(len(others))][: max(1, 4 - len(interesting))]
        options = [_pair_choice(name, rng, p) for p in pool]
        positive = [*ref.program, "counterfact_events", "belong_to"]
        yes = [c for c in options if score_choice(positive, c["program"], scene)]
        no = [c for c in options if not score_choice(positive, c["program"], scene)]
        negated = _negate_for_balance(rng, len(yes), len(no), min(4, len(options)), CORRECT_COUNT_WEIGHTS)
        correct, wrong = (no, yes) if negated else (yes, no)
        program = positive + (["negate"] if negated else [])
        text = f"Which of the following will {'not ' if negated else ''}happen if the {ref.phrase} is removed?"
        picked = _choose_balanced(rng, correct, wrong, min(4, len(options)), CORRECT_COUNT_WEIGHTS)
        question = _finish({"question_type": "counterfactual", "question": text, "program": program}, picked, scene)
        if question is not None and len(question["choices"]) >= 2:
            questions.append(question)
    return questions


def scene_questions(scene: ProgramScene, rng: np.random.Generator, seen: frozenset[int] | None = None,
                    phrasing: str = "shortest") -> list[dict]:
    """All questions of one scene, numbered in CLEVRER's order of types.

    ``seen``: ids of the objects seen in the video (synth.annotate.seen_object_ids);
    only they are named. None: every object (hand-made scenes of tests).
    ``phrasing``: how objects are named (PHRASINGS, module docstring).
    """
    questions = (explanatory_questions(scene, rng, seen, phrasing) + predictive_questions(scene, rng, seen, phrasing)
                 + counterfactual_questions(scene, rng, seen, phrasing))
    out = []
    for k, q in enumerate(questions):
        out.append({"question_id": k, "question_type": q["question_type"], "question": q["question"], "program": q["program"], "choices": q["choices"]})
    return out
