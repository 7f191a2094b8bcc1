"""CLEVRER question programs: a pure, backend-agnostic interpreter.

A program is a postfix token list run on a stack: a token that is not an
operator (``red``, ``first``, ``null``) is pushed as a literal; an operator pops
its arguments (the last pushed is the last argument) and pushes its result.
A multiple-choice option is scored by running ``choice.program +
question.program``; the result ``"yes"`` means the option is correct.

The interpreter runs over a :class:`ProgramScene`: objects (id, colour,
material, shape), events (kind, object ids, frame) and optional callables for
what only a simulator or a tracker knows (counterfactual events for a removed
object, motion at a frame). The scene generator builds one from MuJoCo ground
truth; the planner builds one from events fetched over HTTP. Same semantics.

Semantics (docs/formats.md, DESIGN.md):

* ``events``: the observed events (frame < observed_frames), plus a ``start``
  (frame 0) and an ``end`` (frame observed_frames - 1) marker, in frame order.
* ``unseen_events``: events at frame >= observed_frames (predictive).
* ``all_events``: every possible collision pair, without a frame.
* causal traces: each object's observed events sorted by frame; the ancestors
  of an event are, recursively, the event just before it in the trace of
  every object it involves (the event itself excluded).
* ``counterfact_events(obj)``: the events of the replay with ``obj`` removed
  from the start, within the observed window (frame < observed_frames).
* ``filter_counterfact(events, obj)``: the collisions of ``events`` whose pair
  also collides in that replay.
* ``belong_to(x, events)``: an object belongs when it takes part in an event
  of the list; an event when the list has one of the same kind and the same
  objects (frames are not compared, so predictions and counterfactuals match).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, Iterable, Literal, Mapping, Sequence

COLORS: tuple[str, ...] = ("gray", "red", "blue", "green", "brown", "yellow", "cyan", "purple")
MATERIALS: tuple[str, ...] = ("metal", "rubber")
SHAPES: tuple[str, ...] = ("sphere", "cube", "cylinder")
ORDERS: tuple[str, ...] = ("first", "second", "last")
EVENT_KINDS: tuple[str, ...] = ("collision", "in", "out", "start", "end")

EventKind = Literal["collision", "in", "out", "start", "end"]


class ProgramError(ValueError):
    """A program that cannot run on this scene (bad token, type or stack, no unique match...)."""


@dataclass(frozen=True)
class ObjectRecord:
    """One object: ``id`` (CLEVRER object_id) and its three attributes."""

    id: int
    color: str
    material: str
    shape: str

    def __post_init__(self) -> None:
        if self.color not in COLORS:
            raise ValueError(f"object {self.id}: color: expected one of {COLORS}, got {self.color!r}")
        if self.material not in MATERIALS:
            raise ValueError(f"object {self.id}: material: expected one of {MATERIALS}, got {self.material!r}")
        if self.shape not in SHAPES:
            raise ValueError(f"object {self.id}: shape: expected one of {SHAPES}, got {self.shape!r}")


@dataclass(frozen=True)
class EventRecord:
    """One event. ``objects``: ids involved (a sorted pair for collisions, one id
    for in/out, none for start/end). ``frame``: video frame index, or None for
    the frameless candidate collisions of ``all_events``."""

    kind: EventKind
    objects: tuple[int, ...]
    frame: int | None

    def __post_init__(self) -> None:
        if self.kind not in EVENT_KINDS:
            raise ValueError(f"event.kind: expected one of {EVENT_KINDS}, got {self.kind!r}")
        expected = {"collision": 2, "in": 1, "out": 1, "start": 0, "end": 0}[self.kind]
        if len(self.objects) != expected:
            raise ValueError(f"event.objects: a {self.kind} event involves {expected} object(s), got {self.objects!r}")
        if self.kind == "collision":
            object.__setattr__(self, "objects", tuple(sorted(int(o) for o in self.objects)))


class MotionOracle:
    """What descriptive operators need beyond events (optional; a tracker or simulator provides it)."""

    def is_visible(self, object_id: int, frame: int | None) -> bool:  # pragma: no cover - interface
        raise NotImplementedError

    def is_moving(self, object_id: int, frame: int | None) -> bool:  # pragma: no cover - interface
        raise NotImplementedError

    def direction(self, object_id: int, frame: int) -> str:  # pragma: no cover - interface
        raise NotImplementedError


@dataclass(frozen=True)
class ProgramScene:
    """Everything a program may look at.

    objects: all objects of the video. events: factual events at any frame
    (observed and future; no start/end markers). observed_frames: frames in the
    video. counterfactual: removed object id -> events of the replay without it
    (any frames; the interpreter keeps frame < observed_frames). motion: for
    filter_moving / filter_resting / filter_stationary / query_direction.
    """

    objects: tuple[ObjectRecord, ...]
    events: tuple[EventRecord, ...]
    observed_frames: int = 128
    counterfactual: Callable[[int], Iterable[EventRecord]] | None = None
    motion: MotionOracle | None = None
    _cache: dict = field(default_factory=dict, compare=False, repr=False)

    def object(self, object_id: int) -> ObjectRecord:
        for obj in self.objects:
            if obj.id == object_id:
                return obj
        raise ProgramError(f"unknown object id {object_id}")


def _sorted_events(events: Iterable[EventRecord]) -> tuple[EventRecord, ...]:
    order = {kind: k for k, kind in enumerate(EVENT_KINDS)}
    return tuple(sorted(events, key=lambda e: (-1 if e.frame is None else e.frame, order[e.kind], e.objects)))


# --- the operators -----------------------------------------------------------


class _Runtime:
    """Operators bound to one scene. Values: ObjectRecord, tuple of them,
    EventRecord, tuple of them, 'yes'/'no', int, str."""

    def __init__(self, scene: ProgramScene):
        self.scene = scene

    # sets
    def objects(self):
        return tuple(sorted(self.scene.objects, key=lambda o: o.id))

    def observed(self) -> tuple[EventRecord, ...]:
        cached = self.scene._cache.get("observed")
        if cached is None:
            cached = _sorted_events(e for e in self.scene.events if e.frame is not None and e.frame < self.scene.observed_frames and e.kind not in ("start", "end"))
            self.scene._cache["observed"] = cached
        return cached

    def events(self):
        markers = (EventRecord("start", (), 0), EventRecord("end", (), max(self.scene.observed_frames - 1, 0)))
        return _sorted_events(self.observed() + markers)

    def unseen_events(self):
        return _sorted_events(e for e in self.scene.events if e.frame is not None and e.frame >= self.scene.observed_frames and e.kind not in ("start", "end"))

    def all_events(self):
        ids = sorted(o.id for o in self.scene.objects)
        return tuple(EventRecord("collision", (a, b), None) for i, a in enumerate(ids) for b in ids[i + 1 :])

    def unique(self, items):
        if len(items) != 1:
            raise ProgramError(f"unique: expected exactly one item, got {len(items)}")
        return items[0]

    def count(self, items):
        return len(items)

    def exist(self, items):
        return "yes" if items else "no"

    def negate(self, value):
        return "no" if value == "yes" else "yes"

    def belong_to(self, entry, events):
        real = [e for e in events if e.kind not in ("start", "end")]
        if isinstance(entry, ObjectRecord):
            return "yes" if any(entry.id in e.objects for e in real) else "no"
        return "yes" if any(e.kind == entry.kind and set(e.objects) == set(entry.objects) for e in real) else "no"

    # object filters
    def filter_color(self, objs, value):
        return tuple(o for o in objs if o.color == value)

    def filter_material(self, objs, value):
        return tuple(o for o in objs if o.material == value)

    def filter_shape(self, objs, value):
        return tuple(o for o in objs if o.shape == value)

    def _motion(self) -> MotionOracle:
        if self.scene.motion is None:
            raise ProgramError("this scene has no motion information (needed by filter_moving/resting/stationary, query_direction)")
        return self.scene.motion

    def filter_moving(self, objs, frame):
        m = self._motion()
        return tuple(o for o in objs if m.is_visible(o.id, frame) and m.is_moving(o.id, frame))

    def filter_resting(self, objs, frame):
        m = self._motion()
        return tuple(o for o in objs if m.is_visible(o.id, frame) and not m.is_moving(o.id, frame))

    filter_stationary = filter_resting

    # event filters
    def filter_start(self, events):
        return self.unique(tuple(e for e in events if e.kind == "start"))

    def filter_end(self, events):
        return self.unique(tuple(e for e in events if e.kind == "end"))

    @staticmethod
    def _ids(objs) -> set[int]:
        return {objs.id} if isinstance(objs, ObjectRecord) else {o.id for o in objs}

    def filter_in(self, events, objs):
        ids = self._ids(objs)
        return tuple(e for e in events if e.kind == "in" and e.objects[0] in ids)

    def filter_out(self, events, objs):
        ids = self._ids(objs)
        return tuple(e for e in events if e.kind == "out" and e.objects[0] in ids)

    def filter_collision(self, events, objs):
        ids = self._ids(objs)
        return tuple(e for e in events if e.kind == "collision" and ids & set(e.objects))

    def filter_order(self, events, order):
        index = {"first": 0, "second": 1, "last": -1}[order]
        if not events or (index >= 0 and index >= len(events)):
            raise ProgramError(f"filter_order: no {order} event among {len(events)}")
        return events[index]

    @staticmethod
    def _frame_of(event) -> int:
        if event.frame is None:
            raise ProgramError("the event has no frame (a candidate from all_events)")
        return event.frame

    def filter_before(self, events, event):
        frame = self._frame_of(event)
        return tuple(e for e in events if e.frame is not None and e.frame < frame)

    def filter_after(self, events, event):
        frame = self._frame_of(event)
        return tuple(e for e in events if e.frame is not None and e.frame > frame)

    # queries
    def query_color(self, obj):
        return obj.color

    def query_material(self, obj):
        return obj.material

    def query_shape(self, obj):
        return obj.shape

    def query_frame(self, event):
        return self._frame_of(event)

    def query_object(self, event):
        if event.kind not in ("in", "out"):
            raise ProgramError(f"query_object: expected an in/out event, got {event.kind}")
        return self.scene.object(event.objects[0])

    def query_direction(self, obj, frame):
        return self._motion().direction(obj.id, frame)

    def query_collision_partner(self, event, obj):
        if event.kind != "collision" or obj.id not in event.objects:
            raise ProgramError("query_collision_partner: the object is not in that collision")
        other = event.objects[1] if event.objects[0] == obj.id else event.objects[0]
        return self.scene.object(other)

    # explanatory
    def ancestors(self, event: EventRecord) -> set[EventRecord]:
        traces = self.scene._cache.get("traces")
        if traces is None:
            traces = {}
            for e in self.observed():
                for oid in e.objects:
                    traces.setdefault(oid, []).append(e)
            self.scene._cache["traces"] = traces
        found: set[EventRecord] = set()
        frontier = [event]
        while frontier:
            current = frontier.pop()
            for oid in current.objects:
                trace = traces.get(oid, [])
                if current in trace:
                    k = trace.index(current)
                    if k > 0 and trace[k - 1] not in found:
                        found.add(trace[k - 1])
                        frontier.append(trace[k - 1])
        return found

    def filter_ancestor(self, events, event):
        causes = self.ancestors(event)
        return tuple(e for e in events if e in causes)

    # counterfactual
    def counterfact_events(self, obj):
        if self.scene.counterfactual is None:
            raise ProgramError("this scene has no counterfactual events (needed by counterfact_events)")
        key = ("cf", obj.id)
        cached = self.scene._cache.get(key)
        if cached is None:
            cached = _sorted_events(e for e in self.scene.counterfactual(obj.id) if e.frame is not None and e.frame < self.scene.observed_frames)
            self.scene._cache[key] = cached
        return cached

    def filter_counterfact(self, events, obj):
        pairs = {e.objects for e in self.counterfact_events(obj) if e.kind == "collision"}
        return tuple(e for e in events if e.kind == "collision" and e.objects in pairs)


# --- operator signatures (static types) ---------------------------------------
# Types: object objects event events bool int frame str color material shape order

_FRAME = ("frame", "int", "null")
SIGNATURES: Mapping[str, tuple[tuple[tuple[str, ...], ...], str]] = {
    "objects": ((), "objects"),
    "events": ((), "events"),
    "unseen_events": ((), "events"),
    "all_events": ((), "events"),
    "unique": ((("objects", "events"),), "element"),
    "count": ((("objects", "events"),), "int"),
    "exist": ((("objects", "events"),), "bool"),
    "negate": ((("bool",),), "bool"),
    "belong_to": ((("object", "event"), ("events",)), "bool"),
    "filter_color": ((("objects",), ("color",)), "objects"),
    "filter_material": ((("objects",), ("material",)), "objects"),
    "filter_shape": ((("objects",), ("shape",)), "objects"),
    "filter_resting": ((("objects",), _FRAME), "objects"),
    "filter_moving": ((("objects",), _FRAME), "objects"),
    "filter_stationary": ((("objects",), _FRAME), "objects"),
    "filter_start": ((("events",),), "event"),
    "filter_end": ((("events",),), "event"),
    "filter_in": ((("events",), ("object", "objects")), "events"),
    "filter_out": ((("events",), ("object", "objects")), "events"),
    "filter_collision": ((("events",), ("object", "objects")), "events"),
    "filter_order": ((("events",), ("order",)), "event"),
    "filter_before": ((("events",), ("event",)), "events"),
    "filter_after": ((("events",), ("event",)), "events"),
    "query_color": ((("object",),), "str"),
    "query_material": ((("object",),), "str"),
    "query_shape": ((("object",),), "str"),
    "query_frame": ((("event",),), "frame"),
    "query_object": ((("event",),), "object"),
    "query_direction": ((("object",), _FRAME), "str"),
    "query_collision_partner": ((("event",), ("object",)), "object"),
    "filter_ancestor": ((("events",), ("event",)), "events"),
    "counterfact_events": ((("object",),), "events"),
    "filter_counterfact": ((("events",), ("object",)), "events"),
}
OPERATORS: frozenset[str] = frozenset(SIGNATURES)


def literal_type(token: str) -> str:
    """Static type of a literal token; ProgramError for an unknown token."""
    if token in COLORS:
        return "color"
    if token in MATERIALS:
        return "material"
    if token in SHAPES:
        return "shape"
    if token in ORDERS:
        return "order"
    if token == "null":
        return "null"
    if token.isdigit():
        return "int"
    raise ProgramError(f"unknown token {token!r}: neither an operator nor a colour/material/shape/order/frame literal")


def check_program(tokens: Sequence[str], inputs: Sequence[str] = ()) -> tuple[str, ...]:
    """Type-check a program without a scene; returns the types left on the stack.

    ``inputs`` are the types already on the stack (e.g. ``("object",)`` for a
    question program that consumes the choice's value). Raises ProgramError
    for an unknown token, a missing argument or a type mismatch.
    """
    stack: list[str] = list(inputs)
    for position, token in enumerate(tokens):
        if not isinstance(token, str):
            raise ProgramError(f"token {position}: expected a string, got {token!r}")
        if token not in SIGNATURES:
            stack.append(literal_type(token))
            continue
        argument_types, result = SIGNATURES[token]
        if len(stack) < len(argument_types):
            raise ProgramError(f"token {position} ({token}): needs {len(argument_types)} argument(s), the stack has {len(stack)}")
        arguments = stack[len(stack) - len(argument_types) :] if argument_types else []
        del stack[len(stack) - len(argument_types) :]
        for k, (got, allowed) in enumerate(zip(arguments, argument_types)):
            if got not in allowed:
                raise ProgramError(f"token {position} ({token}): argument {k + 1} must be {'/'.join(allowed)}, got {got}")
        if result == "element":
            result = "object" if arguments[0] == "objects" else "event"
        stack.append(result)
    return tuple(stack)


ATTRIBUTE_FILTERS: Mapping[str, str] = {"filter_color": "color", "filter_material": "material", "filter_shape": "shape"}


def reference_spans(tokens: Sequence[str]) -> list[tuple[int, int]]:
    """(start, end) token positions of each object reference, in order: a run
    ``objects (value filter_color|filter_material|filter_shape)* unique`` from
    its ``objects`` (start) to its ``unique`` (end, inclusive)."""
    spans = []
    k = 0
    while k < len(tokens):
        if tokens[k] != "objects":
            k += 1
            continue
        j = k + 1
        while j + 1 < len(tokens) and tokens[j + 1] in ATTRIBUTE_FILTERS:
            j += 2
        if j < len(tokens) and tokens[j] == "unique":
            spans.append((k, j))
        k = j + 1 if j > k + 1 else k + 1
    return spans


def execute(tokens: Sequence[str], scene: ProgramScene, bound: Sequence[int] | None = None) -> object:
    """Run a program on a scene; returns the single value it leaves.

    bound: the object id each object reference (:func:`reference_spans`, in
    order) stands for, decided beforehand (e.g. by grounding under perceived
    attributes); each such run then pushes that object instead of filtering
    by attributes. None: every reference is resolved by its filters.

    Raises ProgramError when the program is malformed or does not apply to the
    scene (e.g. ``unique`` on zero or several matches, or ``bound`` does not
    give one id per reference).
    """
    runtime = _Runtime(scene)
    stack: list[object] = []
    bound_at: dict[int, int] = {}  # start of a reference -> its object id
    inside: set[int] = set()  # the other positions of bound references (not run)
    if bound is not None:
        spans = reference_spans(tokens)
        if len(spans) != len(bound):
            raise ProgramError(f"bound: {len(bound)} object id(s) for {len(spans)} object reference(s)")
        bound_at = {start: int(object_id) for (start, _), object_id in zip(spans, bound)}
        inside = {k for start, end in spans for k in range(start + 1, end + 1)}
    for position, token in enumerate(tokens):
        if position in inside:
            continue
        if position in bound_at:
            stack.append(scene.object(bound_at[position]))
            continue
        if token not in SIGNATURES:
            literal_type(token)
            stack.append(int(token) if token.isdigit() else (None if token == "null" else token))
            continue
        argument_types, _ = SIGNATURES[token]
        if len(stack) < len(argument_types):
            raise ProgramError(f"token {position} ({token}): needs {len(argument_types)} argument(s), the stack has {len(stack)}")
        arguments = stack[len(stack) - len(argument_types) :] if argument_types else []
        del stack[len(stack) - len(argument_types) :]
        for k, (value, allowed) in enumerate(zip(arguments, argument_types)):
            if not _runtime_check(value, allowed):
                raise ProgramError(f"token {position} ({token}): argument {k + 1} must be {'/'.join(allowed)}, got {_runtime_type(value)}")
        try:
            stack.append(getattr(runtime, token)(*arguments))
        except ProgramError as error:
            raise ProgramError(f"token {position} ({token}): {error}") from None
    if len(stack) != 1:
        raise ProgramError(f"the program leaves {len(stack)} values on the stack, expected 1")
    return stack[0]


def _runtime_type(value: object) -> str:
    if isinstance(value, ObjectRecord):
        return "object"
    if isinstance(value, EventRecord):
        return "event"
    if isinstance(value, tuple):
        if value and isinstance(value[0], EventRecord):
            return "events"
        if value and isinstance(value[0], ObjectRecord):
            return "objects"
        return "empty"
    if value is None:
        return "null"
    if isinstance(value, int):
        return "int"
    if value in ("yes", "no"):
        return "bool"
    if value in COLORS:
        return "color"
    if value in MATERIALS:
        return "material"
    if value in SHAPES:
        return "shape"
    if value in ORDERS:
        return "order"
    return "str"


# An empty tuple is both an empty object list and an empty event list.
_EMPTY_OK = ("objects", "events")


def _accepts(allowed: tuple[str, ...], got: str) -> bool:
    return got in allowed or (got == "empty" and any(a in _EMPTY_OK for a in allowed)) or (got == "int" and "frame" in allowed)


def _runtime_check(value: object, allowed: tuple[str, ...]) -> bool:
    return _accepts(allowed, _runtime_type(value))


def causal_ancestors(scene: ProgramScene, event: EventRecord) -> frozenset[EventRecord]:
    """The ancestors of an observed event in the causal traces (the event itself excluded)."""
    return frozenset(_Runtime(scene).ancestors(event))


def score_choice(question_program: Sequence[str], choice_program: Sequence[str], scene: ProgramScene) -> bool:
    """True when the option is correct: ``choice + question`` evaluates to ``yes``."""
    result = execute(list(choice_program) + list(question_program), scene)
    if result not in ("yes", "no"):
        raise ProgramError(f"a choice + question program must give yes/no, got {result!r}")
    return result == "yes"


def answer_question(question: Mapping[str, object], scene: ProgramScene) -> list[str]:
    """'correct'/'wrong' for each choice of a CLEVRER multiple-choice question."""
    program = question["program"]
    return ["correct" if score_choice(program, choice["program"], scene) else "wrong" for choice in question["choices"]]  # type: ignore[index]
