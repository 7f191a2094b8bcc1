"""The offline program executor: questions -> programs -> tool calls over HTTP -> answers.

Paper Section 3.3 (F_exec + F_ans) without a language model. A
:class:`VideoExecutor` wraps one world registered on the tool server and
fetches, lazily and once per video, everything the CLEVRER programs need:

* ``get_world_summary``: the objects (ids + attributes) for grounding;
* ``list_events`` on the base rollout: the observed events (frame <
  observed_frames), from which the causal traces are built;
* the continuation beyond the observed frames for ``unseen_events``: the base
  rollout when it reaches the prediction horizon, else ``continue_world``
  (the unedited world to the longer horizon, restarted from the fitted
  end-of-video state; never an edited, un-anchored replay);
* ``counterfact_events(obj)``: ``simulate_edit(remove_object, obj)``, one
  edited rollout per removed object, reused by every question of the video,
  with ``compare_rollouts`` for the pairs the removal adds or removes and
  ``check_contact`` on the edited rollout for every collision option; a
  collision of the world's record of the video that the replay does not
  reproduce, and whose causes do not involve the removed object, happens in
  the counterfactual too (the replay cannot tell what the removal does to it).

The events feed :mod:`planner.program` (the same interpreter that computes the
ground truth from MuJoCo), so semantics cannot drift. Where a program cannot
run on the world, the executor says why and decides only what follows without
a guess: an object the world lacks (never in view) takes part in no event;
an option's event the rollout lacks is not listed (except where a predictive question's presupposition decides:
"which event will happen next" with every option missing from the continuation takes the pair that comes closest,
stated as uncertain); an explained event that
occurs several times is decided by its first occurrence where the occurrences disagree (stated as uncertain);
an explained event the world lacks in the video is stood in for by the world's nearest evidence of it (the
pair's first touch or closest approach; the object's first entry/exit) and stated as uncertain;
a reference that matches several objects or none is decided by the attribute
probabilities (planner.grounding) or, in an explanatory question whose explained event the world lacks with
that choice, by the question's presupposition (the likeliest objects with which the world has it), the choice and its probability stated in
the facts (docs/planner.md). The
``trajectory_only`` mode is the ablation of the paper's Figure 4: no
intervention is executed and a counterfactual is answered from the factual
events with the removed object's events dropped.
"""

from __future__ import annotations

import itertools
import math
import time
from dataclasses import dataclass, replace
from typing import Any, Iterable, Literal, Mapping, Sequence

from planner.answer import Answer, ChoiceAnswer, readable
from planner.client import ToolCallError, WorldHandle
from planner.grammar import ParseError
from planner.grounding import Grounding, WorldObject, bound_ids, failed, ground_question, objects_from_summary
from planner.parser import parse_choice, parse_question
from planner.program import EventRecord, ObjectRecord, ProgramError, ProgramScene, causal_ancestors, execute
from world.timebase import CONTACT_EPISODE_GAP_SECONDS, frames_in

Mode = Literal["execute", "trajectory_only"]
MODES: tuple[str, ...] = ("execute", "trajectory_only")
# CLEVRER-style datasets simulate 1.4x the observed window (128 -> 180 frames).
DEFAULT_PREDICTION_FACTOR = 1.4
QUESTION_TAILS = ("belong_to",)
# m/s: how fast the fitted continuation's spread grows after the video. A predictive collision option the
# continuation misses, whose pair still comes within this many metres per second after the video of
# touching, is judged to happen (an uncertain fact says so): the replay's own error after the video is of
# that size (docs/benchmarks.md, "Predictive near misses"), while inside the video it is millimetres, so
# counterfactual replays keep their verdicts.
PREDICTION_SPREAD = 0.02
# Grounding under an explanatory question's presupposition (_presupposed_grounding): the likeliest objects per
# ambiguous reference that are weighed, and the likelihood that the world lacks an event the video shows (1 - the
# recall of the record of observed collisions from video: 0.92 on the held-out looks, 0.71 on Blender; 0.8 taken).
PRESUPPOSITION_CANDIDATES = 3
MISSED_EVENT_LIKELIHOOD = 0.2


def prediction_horizon_for(world_document: Mapping[str, Any], factor: float = DEFAULT_PREDICTION_FACTOR) -> int:
    """Base-rollout frames that cover the predictive window of a CLEVRER-style dataset.

    Registering a world with this horizon makes ``unseen_events`` come from the
    base rollout itself: the factual continuation from the fitted end state
    (the world's anchor), which edited replays do not use.
    """
    return int(math.ceil(int(world_document["observed_frames"]) * factor))


@dataclass(frozen=True)
class ExecutorConfig:
    """mode: "execute" or "trajectory_only" (ablation). prediction_horizon_frames:
    frames the continuation covers (default ceil(1.4 x observed frames)).
    corroborate: also call check_contact on every collision option of a
    predictive / counterfactual question (evidence only; the verdict comes from the events)."""

    mode: Mode = "execute"
    prediction_horizon_frames: int | None = None
    corroborate: bool = True

    def __post_init__(self) -> None:
        if self.mode not in MODES:
            raise ValueError(f"mode: expected one of {MODES}, got {self.mode!r}")
        if self.prediction_horizon_frames is not None and self.prediction_horizon_frames < 1:
            raise ValueError(f"prediction_horizon_frames: must be >= 1, got {self.prediction_horizon_frames}")


def _event_from_record(record: Mapping[str, Any]) -> EventRecord | None:
    kind = record.get("kind")
    if kind not in ("collision", "in", "out"):
        return None  # "stop" events are not CLEVRER events
    return EventRecord(kind, tuple(int(o) for o in record["objects"]), int(record["frame"]))


# CLEVRER's collision definition: one touch is one collision; a pair collides
# anew only after CONTACT_EPISODE_GAP_SECONDS without contact (docs/formats.md). The
# engine may emit several contact events for one touch (multi-body clusters), so they are merged.
COLLISION_DEBOUNCE_SECONDS = CONTACT_EPISODE_GAP_SECONDS


def clevrer_events(records: Iterable[Mapping[str, Any]], fps: float) -> list[EventRecord]:
    """Tool event records -> interpreter events: stop events dropped, exact
    duplicates removed, a pair's collisions within the debounce window merged
    into the first one."""
    window = frames_in(COLLISION_DEBOUNCE_SECONDS, fps)
    events = sorted((e for e in (_event_from_record(r) for r in records) if e is not None), key=lambda e: (e.frame, e.kind, e.objects))
    kept: list[EventRecord] = []
    last_contact: dict[tuple[int, ...], int] = {}
    seen: set[EventRecord] = set()
    for event in events:
        if event in seen:
            continue
        seen.add(event)
        if event.kind == "collision":
            previous = last_contact.get(event.objects)
            last_contact[event.objects] = event.frame  # type: ignore[assignment]
            if previous is not None and event.frame - previous <= window:  # type: ignore[operator]
                continue
        kept.append(event)
    return kept


def _event_order(event: EventRecord) -> tuple:
    """Time order of interpreter events (frameless ones last)."""
    return (event.frame if event.frame is not None else math.inf, event.kind, event.objects)


def describe_event(event: EventRecord) -> str:
    where = "" if event.frame is None else f" at frame {event.frame}"
    if event.kind == "collision":
        return f"collision of objects {event.objects[0]} and {event.objects[1]}{where}"
    if event.kind in ("in", "out"):
        verb = "enters" if event.kind == "in" else "exits"
        return f"object {event.objects[0]} {verb} the view{where}"
    return f"{event.kind}{where}"


def _same_event(a: EventRecord, b: EventRecord) -> bool:
    return a.kind == b.kind and set(a.objects) == set(b.objects)


class VideoExecutor:
    """Answers questions about one world on the server; caches per-video tool results."""

    def __init__(self, world: WorldHandle, config: ExecutorConfig = ExecutorConfig()):
        self.world = world
        self.config = config
        self._summary: dict[str, Any] | None = None
        self._summary_call: int | None = None
        self._base: list[EventRecord] | None = None
        self._base_call: int | None = None
        self._base_horizon = 0
        self._continuation: tuple[list[EventRecord], str, int, int] | None = None  # events, rollout id, call, horizon
        self._counterfactual: dict[int, tuple[list[EventRecord], str, tuple[int, ...], str]] = {}

    # -- what the world says (each fetched once) ---------------------------------

    @property
    def summary(self) -> dict[str, Any]:
        if self._summary is None:
            self._summary = self.world.call("get_world_summary")
            self._summary_call = self.world.last_call.index
        return self._summary

    @property
    def observed_frames(self) -> int:
        return int(self.summary["observed_frames"])

    @property
    def objects(self) -> tuple[WorldObject, ...]:
        return objects_from_summary(self.summary)

    def program_objects(self) -> tuple[ObjectRecord, ...]:
        """Objects the interpreter can filter; an object with an unknown attribute cannot be named, so it is left out."""
        return tuple(ObjectRecord(o.object_id, o.color, o.material, o.shape) for o in self.objects
                     if o.color is not None and o.material is not None and o.shape is not None)

    def base_events(self) -> list[EventRecord]:
        if self._base is None:
            result = self.world.call("list_events", rollout_id="base", kinds=["collision", "in", "out"])
            self._base_call = self.world.last_call.index
            self._base_horizon = int(result["boundaries"]["horizon_frames"])
            self._base = clevrer_events(result["events"], float(self.summary["fps"]))
        return self._base

    def prediction_horizon(self) -> int:
        if self.config.prediction_horizon_frames is not None:
            return self.config.prediction_horizon_frames
        return int(math.ceil(self.observed_frames * DEFAULT_PREDICTION_FACTOR))

    def continuation(self) -> tuple[list[EventRecord], str, int, int]:
        """(events at frame >= observed, rollout id, call index, horizon) of the factual continuation."""
        if self._continuation is None:
            base = self.base_events()
            horizon = self.prediction_horizon()
            if self._base_horizon >= horizon:
                events = [e for e in base if e.frame is not None and self.observed_frames <= e.frame < horizon]
                self._continuation = (events, "base", self._base_call, self._base_horizon)  # type: ignore[arg-type]
            else:
                # The factual world continued without an edit: it restarts from the fitted end-of-video state.
                result = self.world.call("continue_world", horizon_frames=horizon)
                call = self.world.last_call.index
                records = list(result["collisions"]) + list(result["in_out_events"])
                events = [e for e in clevrer_events(records, float(self.summary["fps"])) if e.frame >= self.observed_frames]
                self._continuation = (events, result["rollout_id"], call, horizon)
        return self._continuation

    def counterfactual(self, object_id: int) -> tuple[list[EventRecord], str, tuple[int, ...], str]:
        """(events of the replay without ``object_id``, rollout id, call indices, summary of the change)."""
        if object_id not in self._counterfactual:
            if self.config.mode == "trajectory_only":
                events = [e for e in self.base_events() if object_id not in e.objects]
                note = f"trajectory-only: factual events without object {object_id} (no replay executed)"
                self._counterfactual[object_id] = (events, "base", (self._base_call,), note)  # type: ignore[arg-type]
            else:
                result = self.world.call("simulate_edit", edit_type="remove_object", object_id=object_id, trajectory_detail="summary")
                calls = [self.world.last_call.index]
                records = list(result["collisions"]) + list(result["in_out_events"])
                events = clevrer_events(records, float(self.summary["fps"]))
                kept = self._unreplayed_but_unaffected(object_id)
                if kept:
                    events = sorted(events + kept, key=_event_order)
                rollout_id = result["rollout_id"]
                comparison = self.world.call("compare_rollouts", edited_rollout_id=rollout_id)
                calls.append(self.world.last_call.index)
                note = (f"rollout {rollout_id} (object {object_id} removed): collision pairs added "
                        f"{comparison['added_pairs']}, removed {comparison['removed_pairs']}")
                if kept:
                    note += ("; kept from the world's record of the video (the replay does not reproduce them and "
                             f"object {object_id} takes no part in their causes): " + ", ".join(describe_event(e) for e in kept))
                self._counterfactual[object_id] = (events, rollout_id, tuple(calls), note)
        return self._counterfactual[object_id]

    def _unreplayed_but_unaffected(self, removed: int) -> list[EventRecord]:
        """Collisions of the world's record of the video that its replay does not reproduce (no collision of the pair
        within the debounce window of the recorded frame) and whose causes (ancestors in the causal traces) do not
        involve the removed object: the replay cannot say what the removal does to them, and the video says nothing
        of it changes them, so they happen in the counterfactual too."""
        recorded = self.observed_collisions()
        if not recorded:
            return []
        window = frames_in(COLLISION_DEBOUNCE_SECONDS, float(self.summary["fps"]))
        replayed = [e for e in self.base_events() if e.kind == "collision"]
        scene = self.scene()
        kept = []
        for event in recorded:
            if removed in event.objects:
                continue
            if any(_same_event(e, event) and abs(e.frame - event.frame) <= window for e in replayed):  # type: ignore[operator]
                continue
            if any(removed in cause.objects for cause in causal_ancestors(scene, event)):
                continue
            kept.append(event)
        return kept

    def observed_collisions(self) -> list[EventRecord] | None:
        """The collisions the world keeps as seen in the video (get_world_summary), or None when the
        world does not record them (not fitted to a video): then the replay's are used."""
        recorded = self.summary.get("observed_collisions")
        if recorded is None:
            return None
        return [EventRecord("collision", tuple(sorted(int(o) for o in c["objects"])), int(c["frame"])) for c in recorded]

    def scene(self) -> ProgramScene:
        """The interpreter's view: observed events, the continuation, counterfactuals on demand.

        The observed collisions are the world's record of the video when it has one (a replay
        may miss or repeat a contact the video shows); in/out events come from the replay.
        """
        observed = [e for e in self.base_events() if e.frame is not None and e.frame < self.observed_frames]
        seen = self.observed_collisions()
        if seen is not None:
            observed = sorted([e for e in observed if e.kind != "collision"] + seen,
                              key=lambda e: (e.frame, e.kind, e.objects))
        future = self.continuation()[0] if self._continuation is not None else []
        return ProgramScene(
            objects=self.program_objects(),
            events=tuple(observed + future),
            observed_frames=self.observed_frames,
            counterfactual=lambda object_id: self.counterfactual(object_id)[0],
        )

    # -- answering ----------------------------------------------------------------

    def answer_text(self, question: str, choices: Sequence[str]) -> Answer:
        """Parse the question and its choices, then answer (see :meth:`answer_programs`)."""
        started = time.perf_counter()
        try:
            parsed = parse_question(question)
        except ParseError as error:
            return Answer(question, None, None, tuple(ChoiceAnswer(k, c, None, None, error="question not parsed") for k, c in enumerate(choices)),
                          error=f"question not parsed: {error}", seconds=time.perf_counter() - started)
        programs: list[tuple[str, ...] | None] = []
        errors: list[str | None] = []
        for text in choices:
            try:
                programs.append(parse_choice(text, parsed.question_type))
                errors.append(None)
            except ParseError as error:
                programs.append(None)
                errors.append(f"choice not parsed: {error}")
        answer = self.answer_programs(question, parsed.question_type, parsed.program, list(zip(choices, programs, errors)))
        return _with_seconds(answer, time.perf_counter() - started)

    def answer_programs(self, question: str, question_type: str, program: Sequence[str],
                        choices: Sequence[tuple[str, Sequence[str] | None, str | None]]) -> Answer:
        """Answer a question given its program and (text, program or None, parse error or None) per choice."""
        started = time.perf_counter()
        program = tuple(program)
        method = "trajectory_only" if self.config.mode == "trajectory_only" else "program"
        try:
            objects = self.objects
            # one grounding for the whole question: the question's and its choices' references together
            programs = {k: tuple(p) for k, (_, p, _) in enumerate(choices) if p is not None}
            grounded = ground_question([program, *programs.values()], objects)
            groundings, choice_groundings = grounded[0], dict(zip(programs, grounded[1:]))
        except (ToolCallError, ValueError) as error:
            undecided = tuple(ChoiceAnswer(k, text, None if p is None else tuple(p), None, error=str(error)) for k, (text, p, _) in enumerate(choices))
            return Answer(question, question_type, program, undecided, method=method, error=str(error), seconds=time.perf_counter() - started)
        bad = failed(groundings)
        # A counterfactual that removes an object the world does not contain (it was never
        # observed) changes nothing: the factual events answer it.
        absent_removal = len(groundings) == 1 and groundings[0].absent and _counterfactual_form(program)
        if bad:
            message = "; ".join(g.message() for g in bad)
            undecided = tuple(ChoiceAnswer(k, text, None if p is None else tuple(p), None, error=f"question reference: {message}")
                              for k, (text, p, _) in enumerate(choices))
            return Answer(question, question_type, program, undecided, method=method, groundings=tuple(groundings),
                          error=f"cannot ground the question: {message}", seconds=time.perf_counter() - started)

        # Fetch what this question type needs, then build the interpreter's scene.
        shared_calls: list[int] = [self._summary_call] if self._summary_call is not None else []
        facts: list[str] = [f"grounding: {g.message()}" for g in groundings if g.status != "unique" and not absent_removal]
        bound = bound_ids(groundings)
        try:
            self.base_events()
            shared_calls.append(self._base_call)  # type: ignore[arg-type]
            if question_type == "predictive" or "unseen_events" in program:
                events, rollout_id, call, horizon = self.continuation()
                shared_calls.append(call)
                facts.append(f"unseen events: frames {self.observed_frames}..{horizon - 1} of rollout {rollout_id!r}: "
                             + (", ".join(describe_event(e) for e in events) or "none"))
            scene = self.scene()
            if self.observed_collisions() is not None:
                facts.append("observed collisions: the world's record of the video (get_world_summary), "
                             "not the replay")
            if absent_removal:
                removed = None
                reference = tuple(e for e in scene.events if e.frame is not None and e.frame < scene.observed_frames)
                facts.append(f"{groundings[0].message()}: an object the world does not contain (never observed) cannot change it, "
                             f"so the factual events before frame {scene.observed_frames} answer: "
                             + (", ".join(describe_event(e) for e in reference) or "none"))
            else:
                removed = _removed_object(program, groundings)
                if removed is not None:
                    events, rollout_id, calls, note = self.counterfactual(removed)
                    shared_calls.extend(calls)
                    facts.append(note)
                regrounded = _presupposed_grounding(program, scene, groundings)
                if regrounded is not None:
                    groundings, note = regrounded
                    bound = bound_ids(groundings)
                    facts.append(note)
                    # the options are grounded again around the question's phrases, now pinned to these objects
                    pinned = {g.query: g.object_id for g in groundings}
                    choice_groundings = dict(zip(programs, ground_question([program, *programs.values()], objects, pinned)[1:]))
                targets = _explained_event_candidates(program, scene, bound)
                kind = _explained_event_kind(program)
                if targets is not None and not targets and bound is not None and kind is not None:
                    # The explained event is not in the world's record of the video: the world's
                    # nearest evidence of it stands in (stated as uncertain), never no verdict.
                    if kind == "collision" and len(set(bound)) == 2:
                        stand_in, note, call = self._stand_in_collision(tuple(sorted(set(bound))))
                        shared_calls.append(call)
                    elif kind in ("in", "out") and len(set(bound)) == 1:
                        stand_in, note = self._stand_in_entry_or_exit(kind, bound[0])
                    else:
                        raise ProgramError(f"the explained {kind} event is not in the world")
                    facts.append(note)
                    scene = replace(scene, events=tuple(sorted((*scene.events, stand_in), key=_event_order)), _cache={})
                    return self._answer_each_occurrence(question, question_type, program, choices, scene, (stand_in,),
                                                        groundings, shared_calls, facts, method, started, choice_groundings)
                if targets is not None and len(targets) > 1:
                    return self._answer_each_occurrence(question, question_type, program, choices, scene, targets,
                                                        groundings, shared_calls, facts, method, started, choice_groundings)
                reference, reference_fact = self._reference_list(program, scene, bound)
                if reference_fact:
                    facts.append(reference_fact)
        except (ToolCallError, ProgramError) as error:
            undecided = tuple(ChoiceAnswer(k, text, None if p is None else tuple(p), None, error=str(error)) for k, (text, p, _) in enumerate(choices))
            return Answer(question, question_type, program, undecided, method=method, groundings=tuple(groundings),
                          facts=tuple(facts), error=str(error), tool_calls=tuple(shared_calls), seconds=time.perf_counter() - started)

        answers = []
        all_groundings = list(groundings)
        contacts: dict[int, Mapping[str, Any]] = {}
        for k, (text, choice_program, parse_error) in enumerate(choices):
            answers.append(self._answer_choice(k, text, choice_program, parse_error, program, question_type, scene, reference,
                                               removed, all_groundings, membership_only=absent_removal, question_bound=bound,
                                               contacts=contacts, grounded=choice_groundings.get(k, ())))
        if question_type == "predictive" and _asks_next_event(program):
            answers = _presupposed_next_event(answers, contacts)
        used = sorted({*shared_calls, *(i for a in answers for i in a.tool_calls)})
        distinct = tuple({(g.reference, g.object_ids): g for g in all_groundings}.values())
        return Answer(question, question_type, program, tuple(answers), method=method, groundings=distinct,
                      facts=tuple(facts), tool_calls=tuple(used), seconds=time.perf_counter() - started)

    def _answer_each_occurrence(self, question, question_type, program, choices, scene, targets, groundings, shared_calls,
                                facts, method, started, choice_groundings) -> Answer:
        """The explained event occurs several times in the world (the question names it as one): answer
        for each occurrence's causes. Where the occurrences disagree, the first one decides: the video
        shows one such event, and a fitted replay's extra touches of a pair come after the real one
        (a pair that meets again later); the disagreement is stated in the option's facts."""
        per_target = []
        for target in targets:
            causes = causal_ancestors(scene, target)
            reference = tuple(e for e in scene.events if e in causes)
            per_target.append((target, reference))
            facts.append(f"causes of the {describe_event(target)}: " + (", ".join(describe_event(e) for e in reference) or "none"))
        if len(targets) > 1:
            facts.insert(0, f"the explained event occurs {len(targets)} times in the world; where the occurrences disagree "
                            f"on an option, the first ({describe_event(targets[0])}) decides")
        answers, all_groundings = [], list(groundings)
        for k, (text, choice_program, parse_error) in enumerate(choices):
            options = [self._answer_choice(k, text, choice_program, parse_error, program, question_type, scene, reference,
                                           None, all_groundings, membership_only=True, grounded=choice_groundings.get(k, ()))
                       for _, reference in per_target]
            verdicts = {o.verdict for o in options}
            if len(verdicts) == 1:
                merged = options[0].facts + tuple(f for o in options[1:] for f in o.facts if f not in options[0].facts)
                answers.append(ChoiceAnswer(k, text, options[0].program, options[0].verdict, facts=merged, error=options[0].error))
            else:
                first = options[0]
                note = ("uncertain: the occurrences disagree on this option ("
                        + ", ".join(f"{describe_event(t)}: {o.verdict}" for (t, _), o in zip(per_target, options))
                        + "); decided by the first occurrence")
                answers.append(ChoiceAnswer(k, text, first.program, first.verdict, facts=(note, *first.facts), error=first.error))
        distinct = tuple({(g.reference, g.object_ids): g for g in all_groundings}.values())
        return Answer(question, question_type, program, tuple(answers), method=method, groundings=distinct, facts=tuple(facts),
                      tool_calls=tuple(sorted(set(shared_calls))), seconds=time.perf_counter() - started)

    def _stand_in_collision(self, pair: tuple[int, int]) -> tuple[EventRecord, str, int]:
        """(stand-in event, uncertainty fact, call index) for an explained collision of ``pair`` that the
        world's record of the video lacks: check_contact on the base rollout over the video gives the
        pair's first touch, else its closest approach; that frame stands in for the collision."""
        a, b = pair
        result = self.world.call("check_contact", object_a=a, object_b=b, rollout_id="base",
                                 frame_start=0, frame_end=self.observed_frames - 1)
        call = self.world.last_call.index
        if result.get("first_frame") is not None:
            frame, how = int(result["first_frame"]), f"their footprints touch at frame {result['first_frame']} in the replay"
        elif result.get("nearest_frame") is not None:
            frame = int(result["nearest_frame"])
            how = f"their closest approach in the replay is {readable(result.get('nearest_distance'))} m at frame {frame}"
        else:
            frame, how = self.observed_frames - 1, "they are never present together in the replay (the end of the video stands in)"
        event = EventRecord("collision", pair, frame)
        return event, (f"uncertain: the explained collision of objects {a} and {b} is not in the world's record of the "
                       f"video; {how}, so its causes are taken as those of a collision there"), call

    def _stand_in_entry_or_exit(self, kind: str, object_id: int) -> tuple[EventRecord, str]:
        """(stand-in event, uncertainty fact) for an explained entry / exit of ``object_id`` that the world
        lacks in the video: the world's first such event of the object (the base rollout, beyond the video
        too), moved to the last observed frame if later; without one, the end of the video (exit) or its
        start (entry)."""
        found = [e for e in self.base_events() if e.kind == kind and e.objects == (object_id,) and e.frame is not None]
        verb = "exit" if kind == "out" else "entry"
        if found:
            frame = min(found[0].frame, self.observed_frames - 1)
            how = f"the world's {verb} of object {object_id} is at frame {found[0].frame}"
        else:
            frame = self.observed_frames - 1 if kind == "out" else 0
            how = f"the world has no {verb} of object {object_id}"
        return EventRecord(kind, (object_id,), frame), (
            f"uncertain: the explained {verb} of object {object_id} is not among the world's events of the video; {how}, "
            f"so its causes are taken as those of an {verb} at frame {frame}")

    def _reference_list(self, program: tuple[str, ...], scene: ProgramScene,
                        bound: list[int] | None) -> tuple[tuple[EventRecord, ...] | None, str | None]:
        """The event list a ``... belong_to [negate]`` question tests its choices against, and a fact naming it
        (bound: the grounded object id of each of the program's references)."""
        tail = _without_negate(program)
        if not tail or tail[-1] != "belong_to":
            return None, None
        value = execute(list(tail[:-1]), scene, bound=bound)
        if not isinstance(value, tuple):
            return None, None
        events = tuple(e for e in value if isinstance(e, EventRecord))
        text = ", ".join(describe_event(e) for e in events) or "none"
        if "filter_ancestor" in tail:
            return events, f"causes (ancestor events in the causal traces) of the explained event: {text}"
        if "counterfact_events" in tail:
            return events, f"events of the replay before frame {scene.observed_frames}: {text}"
        if "unseen_events" in tail:
            return events, None  # already stated with the continuation
        return events, f"reference events: {text}"

    def _answer_choice(self, k: int, text: str, choice_program: Sequence[str] | None, parse_error: str | None,
                       program: tuple[str, ...], question_type: str, scene: ProgramScene,
                       reference: tuple[EventRecord, ...] | None, removed: int | None, all_groundings: list[Grounding],
                       membership_only: bool = False, question_bound: list[int] | None = None,
                       contacts: dict[int, Mapping[str, Any]] | None = None,
                       grounded: Sequence[Grounding] = ()) -> ChoiceAnswer:
        """One verdict. ``membership_only``: the question program cannot run (its removed object is
        absent), so the option is tested against ``reference`` directly, as ``belong_to`` does.
        ``question_bound``: the grounded object ids of the question program's references.
        ``contacts``: filled with option k's check_contact result when corroborated.
        ``grounded``: the option's groundings from the question's joint grounding (grounding.ground_question).
        The stages: parse -> ground (:func:`_ungrounded_option`) -> run (:meth:`_run_option`, or
        :func:`_option_from_selection` when the program does not apply) -> facts per value kind
        (:data:`OPTION_FACTS`) -> corroboration."""
        if choice_program is None:
            return ChoiceAnswer(k, text, None, None, error=parse_error or "choice not parsed")
        choice_program = tuple(choice_program)
        groundings = list(grounded)
        all_groundings.extend(groundings)
        negated = bool(program) and program[-1] == "negate"
        bad = failed(groundings)
        absent = [g for g in groundings if g.absent]
        if bad or (absent and reference is not None):
            return _ungrounded_option(k, text, choice_program, bad or absent, reference, negated)
        bound = bound_ids(groundings)
        inferred = [f"grounding: {g.message()}" for g in groundings if g.status != "unique"]
        try:
            value, result = self._run_option(choice_program, program, scene, reference, negated, membership_only,
                                             bound, question_bound)
        except ProgramError as error:
            selected = _option_from_selection(k, text, choice_program, scene, reference, negated, error, bound)
            return replace(selected, facts=(*inferred, *selected.facts))
        if result not in ("yes", "no"):
            return ChoiceAnswer(k, text, choice_program, None, error=f"the program gives {result!r}, not yes/no")
        facts: list[str] = list(inferred)
        calls: list[int] = []
        if reference is not None:
            describe = OPTION_FACTS.get(type(value))
            if describe is not None:
                facts.append(describe(value, reference))
            if negated:
                facts.append(NEGATED_FACT)
        if self.config.corroborate and isinstance(value, EventRecord) and value.kind == "collision" and question_type in ("predictive", "counterfactual"):
            note = self._corroborate(value, question_type, removed)
            if note is not None:
                facts.append(note[0])
                calls.append(note[1])
                if contacts is not None:
                    contacts[k] = note[2]
                if question_type == "predictive" and result == "no" and not negated:
                    near = self._within_prediction_spread(note[2])
                    if near is not None:
                        result = "yes"
                        facts.append(near)
        return ChoiceAnswer(k, text, choice_program, "correct" if result == "yes" else "wrong", facts=tuple(facts), tool_calls=tuple(calls))

    def _within_prediction_spread(self, contact: Mapping[str, Any]) -> str | None:
        """An uncertain fact when a pair the continuation does not make collide comes within the prediction's
        spread of touching (PREDICTION_SPREAD metres per second after the video), else None."""
        gap, frame = contact.get("nearest_distance"), contact.get("nearest_frame")
        if gap is None or frame is None:
            return None
        seconds = (int(frame) - (self.observed_frames - 1)) / float(self.summary["fps"])
        spread = PREDICTION_SPREAD * max(seconds, 0.0)
        if float(gap) > spread:
            return None
        return (f"uncertain: the continuation makes no collision of the pair, but they come within {readable(gap)} m "
                f"at frame {frame}, inside the prediction's spread there ({readable(spread)} m): judged a collision")

    @staticmethod
    def _run_option(choice_program: tuple[str, ...], program: tuple[str, ...], scene: ProgramScene,
                    reference: tuple[EventRecord, ...] | None, negated: bool, membership_only: bool,
                    choice_bound: list[int] | None, question_bound: list[int] | None) -> tuple[Any, Any]:
        """(the option's value, "yes"/"no" or what the program gave); ProgramError when it does not apply.
        choice_bound / question_bound: the grounded object ids of the references of each program."""
        value = execute(list(choice_program), scene, bound=choice_bound)
        if not membership_only:
            both = None if choice_bound is None or question_bound is None else [*choice_bound, *question_bound]
            return value, execute(list(choice_program) + list(program), scene, bound=both)
        if reference is None or not isinstance(value, (ObjectRecord, EventRecord)):
            raise ProgramError("the option is neither an object nor an event")
        listed = (any(value.id in e.objects for e in reference) if isinstance(value, ObjectRecord)
                  else any(_same_event(value, e) for e in reference))
        return value, "yes" if listed != negated else "no"

    def _corroborate(self, event: EventRecord, question_type: str, removed: int | None) -> tuple[str, int, Mapping[str, Any]] | None:
        """check_contact on the rollout the verdict came from: its fact, call index and result (evidence; the
        verdict comes from the events, except a predictive near miss, _within_prediction_spread)."""
        a, b = event.objects
        if question_type == "predictive":
            _, rollout_id, _, horizon = self.continuation()
            frames = {"frame_start": self.observed_frames, "frame_end": horizon - 1}
        else:
            if removed is None or self.config.mode == "trajectory_only":
                return None
            rollout_id = self.counterfactual(removed)[1]
            frames = {"frame_start": 0, "frame_end": self.observed_frames - 1}
        try:
            result = self.world.call("check_contact", object_a=a, object_b=b, rollout_id=rollout_id, **frames)
        except ToolCallError as error:
            return f"check_contact({a}, {b}) on {rollout_id!r} failed: {error}", self.world.last_call.index, {}
        change = ""
        if isinstance(result.get("base_comparison"), Mapping):
            change = f", versus base: {result['base_comparison'].get('change')}"
        return (f"check_contact({a}, {b}) on rollout {rollout_id!r} frames {frames['frame_start']}..{frames['frame_end']}: "
                f"{result.get('status')} (first frame {readable(result.get('first_frame'))}, "
                f"nearest {readable(result.get('nearest_distance'))} m{change})",
                self.world.last_call.index, result)


def _asks_next_event(program: Sequence[str]) -> bool:
    """The question asks which of its options happens after the video (``unseen_events belong_to``, not negated)."""
    return bool(program) and "unseen_events" in program and program[-1] == "belong_to"


def _presupposed_next_event(answers: list[ChoiceAnswer], contacts: Mapping[int, Mapping[str, Any]]) -> list[ChoiceAnswer]:
    """"Which event will happen next?" presupposes that one of its events happens. When the continuation makes
    none of them (two or more options, every one judged wrong), the option whose pair comes closest in the
    continuation (check_contact's nearest distance, ``contacts`` by option index) is judged to happen, stated as
    uncertain: its error after the video grows with time (PREDICTION_SPREAD), so a miss there is weak evidence,
    and the closest pair is the best of it. Any other case is left as decided."""
    if len(answers) < 2 or any(a.verdict != "wrong" for a in answers):
        return answers
    gaps = {k: float(c["nearest_distance"]) for k, c in contacts.items() if c.get("nearest_distance") is not None}
    if not gaps:
        return answers
    chosen = min(gaps, key=gaps.__getitem__)
    contact = contacts[chosen]
    note = (f"uncertain: the question presupposes that one of its events happens next and the continuation makes none "
            f"of them; this option's pair comes closest ({readable(contact['nearest_distance'])} m at frame "
            f"{readable(contact.get('nearest_frame'))}): judged to happen")
    return [replace(a, verdict="correct", facts=(*a.facts, note)) if a.choice_id == chosen else a for a in answers]


NEGATED_FACT = "the question is negated: the option is correct when the event/object is NOT listed"


def _object_facts(value: ObjectRecord, reference: tuple[EventRecord, ...]) -> str:
    involved = [e for e in reference if value.id in e.objects]
    return (f"object {value.id} ({value.color} {value.material} {value.shape}) takes part in "
            + (", ".join(describe_event(e) for e in involved) if involved else f"none of the {len(reference)} listed events"))


def _event_facts(value: EventRecord, reference: tuple[EventRecord, ...]) -> str:
    found = [e for e in reference if _same_event(e, value)]
    return f"{describe_event(value)}: " + ("found, " + ", ".join(describe_event(e) for e in found) if found
                                           else f"not among the {len(reference)} listed events")


# What an option's value says about the reference list, by the kind of value its program gives.
OPTION_FACTS: dict[type, Any] = {ObjectRecord: _object_facts, EventRecord: _event_facts}


def _ungrounded_option(k: int, text: str, choice_program: tuple[str, ...], bad: Sequence[Grounding],
                       reference: tuple[EventRecord, ...] | None, negated: bool) -> ChoiceAnswer:
    """An option whose reference names no object of the world: undecided when the world has no objects (or
    nothing to test against); an object the world does not contain (never observed) takes part in no event."""
    if reference is None or any(g.status == "undecided" for g in bad):
        return ChoiceAnswer(k, text, choice_program, None, error="; ".join(g.message() for g in bad))
    facts = [f"{g.message()}: an object the world does not contain takes part in none of its events" for g in bad]
    if negated:
        facts.append(NEGATED_FACT)
    return ChoiceAnswer(k, text, choice_program, "correct" if negated else "wrong", facts=tuple(facts))


def _option_from_selection(k: int, text: str, choice_program: tuple[str, ...], scene: ProgramScene,
                           reference: tuple[EventRecord, ...] | None, negated: bool, error: ProgramError,
                           bound: list[int] | None = None) -> ChoiceAnswer:
    """An event option whose program does not apply (its event is absent, or occurs several times):
    decided by membership of the events it selects (bound: the grounded ids of its references)."""
    candidates = _event_selection(choice_program, scene, bound)
    if candidates is None or reference is None:
        return ChoiceAnswer(k, text, choice_program, None, error=f"program does not apply: {error}")
    if not candidates:
        # The option names an event the world's rollout does not contain: it cannot be listed.
        listed = False
        facts = ["the event the option names does not occur in the world's rollout, so it is not among the listed events"]
    else:
        # Several touches of the same pair: belong_to compares kind and objects only, so any of them decides.
        listed = any(_same_event(candidates[0], e) for e in reference)
        facts = [f"the option's event occurs {len(candidates)} times ({', '.join(describe_event(c) for c in candidates)}); "
                 f"{'listed' if listed else 'not listed'} (membership ignores frames)"]
    if negated:
        facts.append(NEGATED_FACT)
    return ChoiceAnswer(k, text, choice_program, "correct" if listed != negated else "wrong", facts=tuple(facts))


def _event_selection(choice_program: tuple[str, ...], scene: ProgramScene,
                     bound: list[int] | None = None) -> tuple[EventRecord, ...] | None:
    """The events an event choice (``events|all_events ... filter_collision|in|out unique``) selects before
    ``unique``; None for other choices or when the selection itself fails."""
    if len(choice_program) < 2 or choice_program[0] not in ("events", "all_events", "unseen_events") or choice_program[-1] != "unique":
        return None
    try:
        candidates = execute(list(choice_program[:-1]), scene, bound=bound)
    except ProgramError:
        return None
    if not isinstance(candidates, tuple) or any(not isinstance(c, EventRecord) for c in candidates):
        return None
    return candidates


def _without_negate(program: Sequence[str]) -> list[str]:
    """The program's operators without a trailing ``negate`` (the ``belong_to [negate]`` forms share their body)."""
    return list(program[:-1]) if program and program[-1] == "negate" else list(program)


def _explained_event_candidates(program: Sequence[str], scene: ProgramScene,
                                bound: list[int] | None = None) -> tuple[EventRecord, ...] | None:
    """For ``events <E> filter_ancestor belong_to [negate]`` with E = ``events ... unique``: the events E
    selects before ``unique`` (None for other programs or when the selection fails; bound: the grounded
    ids of the program's references)."""
    tail = _without_negate(program)
    if len(tail) < 5 or tail[0] != "events" or tail[-2:] != ["filter_ancestor", "belong_to"] or tail[-3] != "unique" or tail[1] != "events":
        return None
    try:
        candidates = execute(tail[1:-3], scene, bound=bound)
    except ProgramError:
        return None
    if not isinstance(candidates, tuple) or any(not isinstance(c, EventRecord) for c in candidates):
        return None
    return candidates


def _presupposed_grounding(program: Sequence[str], scene: ProgramScene,
                           groundings: list[Grounding]) -> tuple[list[Grounding], str] | None:
    """An explanatory question presupposes its explained event. When its references are inferred (ambiguous
    attributes) and the world lacks the explained event (in the video) with the objects they were grounded to,
    each other assignment (the PRESUPPOSITION_CANDIDATES likeliest objects per reference, distinct) with which
    the world has it is weighed by its likelihood shares, the grounding by attributes by its shares times
    MISSED_EVENT_LIKELIHOOD; the best replaces the grounding (with the fact that says so). None: nothing changes."""
    if _explained_event_kind(program) is None or not any(g.status == "inferred" for g in groundings):
        return None
    if any(g.status == "undecided" for g in groundings):
        return None
    options = [[(g.object_id, 1.0)] if g.status != "inferred" else
               list(g.probabilities[:PRESUPPOSITION_CANDIDATES]) for g in groundings]
    queries = [g.query for g in groundings]

    def has_event(ids: tuple[int, ...]) -> bool:
        targets = _explained_event_candidates(program, scene, list(ids)) or ()
        return any(e.frame is not None and e.frame < scene.observed_frames for e in targets)  # explained events are in the video

    current = tuple(g.object_id for g in groundings)
    if has_event(current):
        return None
    # the grounding by attributes contradicts the presupposition: an assignment that satisfies it replaces it when
    # its likelihood beats the contradicted one's times MISSED_EVENT_LIKELIHOOD
    best, best_score = current, math.prod(1.0 if g.status != "inferred" else (g.probability or 0.0) for g in groundings) * MISSED_EVENT_LIKELIHOOD
    for combination in itertools.product(*options):
        ids = tuple(i for i, _ in combination)
        # distinct references name distinct objects (equal queries one object)
        if any(ids[a] == ids[b] and queries[a] != queries[b] for a in range(len(ids)) for b in range(a)):
            continue
        value = math.prod(p for _, p in combination)
        if value > best_score and has_event(ids):
            best, best_score = ids, value
    if best == current:
        return None
    changed = [(g, i) for g, i in zip(groundings, best) if g.object_id != i]
    note = ("grounding: the question presupposes its explained event, which the world has with "
            + ", ".join(f"'{g.reference}' -> object {i} (p={dict(g.probabilities).get(i, 0.0):.2f})" for g, i in changed)
            + " and not with the likeliest by attributes ("
            + ", ".join(f"object {g.object_id}, p={g.probability or 0.0:.2f}" for g, _ in changed) + ")")
    return [replace(g, object_ids=(i,)) for g, i in zip(groundings, best)], note


def _explained_event_kind(program: Sequence[str]) -> str | None:
    """"collision" / "in" / "out": the kind of the explained event of ``events <E> filter_ancestor belong_to``."""
    tail = _without_negate(program)
    if len(tail) < 5 or tail[-2:] != ["filter_ancestor", "belong_to"] or tail[-3] != "unique":
        return None
    return {"filter_collision": "collision", "filter_in": "in", "filter_out": "out"}.get(tail[-4])


def _counterfactual_form(program: Sequence[str]) -> bool:
    """``OBJ counterfact_events belong_to [negate]``: the generator's counterfactual question."""
    tail = _without_negate(program)
    return len(tail) >= 3 and tail[-2:] == ["counterfact_events", "belong_to"] and tail[0] == "objects"


def _removed_object(program: Sequence[str], groundings: Sequence[Grounding]) -> int | None:
    """The object a ``... counterfact_events`` / ``filter_counterfact`` question removes (its last reference before the operator)."""
    for operator in ("counterfact_events", "filter_counterfact"):
        if operator in program:
            position = list(program).index(operator)
            before = sum(1 for k in range(position) if program[k] == "objects")
            if before and before <= len(groundings):
                return groundings[before - 1].object_id
    return None


def _with_seconds(answer: Answer, seconds: float) -> Answer:
    return replace(answer, seconds=seconds)


def truth_of(question: Mapping[str, Any]) -> list[str | None]:
    """The dataset's 'correct'/'wrong' per choice (None where absent)."""
    return [c.get("answer") for c in question.get("choices", [])]


def answer_dataset_question(executor: VideoExecutor, question: Mapping[str, Any]) -> Answer:
    """Answer a CLEVRER question record from its text (parsed here; the dataset's programs are not used)."""
    return executor.answer_text(str(question["question"]), [str(c["choice"]) for c in question["choices"]])
