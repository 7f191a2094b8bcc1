"""The offline program executor over HTTP, checked against the engine run directly in the test.

The expected answers come from ``world.rollout.simulate`` called here, in-process,
on the same world the server hosts: the executor must reach them through the HTTP
tools only (list_events, simulate_edit, compare_rollouts, check_contact).
"""

from __future__ import annotations

import dataclasses
import itertools
import json
import math

import httpx
import pytest

from planner.client import ToolClient
from planner.executor import COLLISION_DEBOUNCE_SECONDS, ExecutorConfig, VideoExecutor, clevrer_events
from planner.program import EventRecord, ProgramScene, causal_ancestors
from world.camera import look_at_camera
from world.io import world_to_dict
from world.rollout import default_horizon, simulate
from world.types import Body, BodyState, Edit, Shape, World

COLOR = {0: "red", 1: "blue", 2: "green", 3: "yellow", 4: "purple", 5: "gray"}  # six_object_world


def _collision_pairs(rollout, below: int | None = None, at_least: int | None = None) -> set[tuple[int, int]]:
    return {tuple(sorted(e.bodies)) for e in rollout.events if e.kind == "collision"
            and (below is None or e.frame < below) and (at_least is None or e.frame >= at_least)}


def _pair_text(a: int, b: int) -> str:
    return f"The {COLOR[a]} object collides with the {COLOR[b]} object"


@pytest.fixture()
def six(tool_client, six_document):
    world = tool_client.create_world(six_document)
    return VideoExecutor(world)


@pytest.mark.parametrize("removed", [0, 1, 2, 3, 4, 5])
@pytest.mark.parametrize("negated", [False, True])
def test_counterfactual_verdicts_match_engine_replays(six, six_world, removed, negated):
    replay = simulate(six_world, [Edit("remove_object", removed)])
    expected_pairs = _collision_pairs(replay, below=six_world.observed_frames)
    pairs = list(itertools.combinations([i for i in range(6) if i != removed], 2))
    question = f"Which of the following will {'not ' if negated else ''}happen if the {COLOR[removed]} object is removed?"
    answer = six.answer_text(question, [_pair_text(a, b) for a, b in pairs])
    expected = ["correct" if ((a, b) in expected_pairs) != negated else "wrong" for a, b in pairs]
    assert answer.error is None
    assert answer.verdicts == expected
    edits = [c for c in six.world.calls if c.tool == "simulate_edit" and c.arguments.get("edit_type") == "remove_object"]
    assert [c.arguments["object_id"] for c in edits] == [removed]
    assert {c.index for c in edits} <= set(answer.tool_calls)


def test_one_replay_per_removed_object_reused_across_questions(six):
    first = six.answer_text("Which of the following will happen if the blue object is removed?", [_pair_text(0, 2)])
    second = six.answer_text("Which of the following will not happen if the blue object is removed?", [_pair_text(2, 3), _pair_text(0, 2)])
    removals = [c for c in six.world.calls if c.tool == "simulate_edit" and c.arguments.get("edit_type") == "remove_object"]
    assert len(removals) == 1
    # Removing blue (1) lets red (0) reach green (2) directly: a collision that never happened.
    assert first.verdicts == ["correct"]
    assert second.verdicts == ["wrong", "wrong"]


def test_trajectory_only_ablation_answers_from_factual_events(tool_client, six_document, six_world):
    """Without execution, a collision that only the replay produces cannot be predicted."""
    world = tool_client.create_world(six_document)
    ablation = VideoExecutor(world, ExecutorConfig(mode="trajectory_only"))
    pairs = [(0, 2), (2, 3), (3, 4), (0, 3)]
    answer = ablation.answer_text("Which of the following will happen if the blue object is removed?", [_pair_text(a, b) for a, b in pairs])
    factual = _collision_pairs(simulate(six_world), below=128)
    assert answer.verdicts == ["correct" if p in factual and 1 not in p else "wrong" for p in pairs]
    assert answer.verdicts[0] == "wrong"  # (0, 2) only collides when the world is replayed without blue
    assert not any(c.tool == "simulate_edit" for c in world.calls)
    assert answer.method == "trajectory_only"


def test_explanatory_verdicts_follow_the_causal_traces(six, six_world):
    rollout = simulate(six_world)
    events = tuple(EventRecord(e.kind, tuple(e.bodies), e.frame) for e in rollout.events if e.kind in ("collision", "in", "out"))
    scene = ProgramScene(objects=(), events=events)
    target = EventRecord("collision", (3, 4), next(e.frame for e in events if e.objects == (3, 4)))
    causes = causal_ancestors(scene, target)
    responsible = {o for e in causes for o in e.objects}
    choices = [f"the presence of the {COLOR[i]} object" for i in range(6)]
    choices += ["the purple object's entrance", "the collision between the red object and the blue object",
                "the gray object's exiting the scene"]
    truth = ["correct" if i in responsible else "wrong" for i in range(6)]
    truth += ["correct" if any(e.kind == "in" and e.objects == (4,) for e in causes) else "wrong",
              "correct" if any(e.kind == "collision" and e.objects == (0, 1) for e in causes) else "wrong",
              "correct" if any(e.kind == "out" and e.objects == (5,) for e in causes) else "wrong"]
    answer = six.answer_text("Which of the following is responsible for the collision between the yellow object and the purple object?", choices)
    assert answer.verdicts == truth
    assert truth.count("correct") >= 3 and "wrong" in truth  # the chain makes several causes, the gray sphere none
    negated = six.answer_text("Which of the following is not responsible for the collision between the yellow object and the purple object?", choices)
    assert negated.verdicts == ["wrong" if t == "correct" else "correct" for t in truth]


def test_an_event_the_world_does_not_contain_is_not_a_cause(six):
    question = "Which of the following is responsible for the collision between the yellow object and the purple object?"
    answer = six.answer_text(question, ["the collision between the red object and the gray object"])
    assert answer.verdicts == ["wrong"]
    assert "does not occur" in answer.choices[0].facts[0]
    negated = six.answer_text(question.replace("is responsible", "is not responsible"), ["the collision between the red object and the gray object"])
    assert negated.verdicts == ["correct"]


def _slow_world():
    """Two slow pairs that collide after the video: ~frame 140 (inside the base horizon) and ~frame 165 (beyond it)."""
    cube = Shape("cube", half_extent=0.2)
    bodies = (
        Body(0, cube, BodyState((-2.0, 0.0, 0.2), (0.30, 0.0, 0.0)), friction=0.001, color="red", material="metal"),
        Body(1, cube, BodyState((0.0, 0.0, 0.2)), friction=0.001, color="blue", material="rubber"),
        Body(2, cube, BodyState((-2.0, 2.0, 0.2), (0.275, 0.0, 0.0)), friction=0.001, color="green", material="metal"),
        Body(3, cube, BodyState((0.0, 2.0, 0.2)), friction=0.001, color="yellow", material="rubber"),
    )
    return World(bodies=bodies, fps=25.0, observed_frames=128, camera=look_at_camera((0.0, -9.0, 6.0), (0.0, 1.0, 0.0)), id="slow-pairs")


def test_predictive_uses_the_continuation_beyond_the_base_horizon(tool_client):
    world = _slow_world()
    horizon = math.ceil(128 * 1.4)
    future = _collision_pairs(simulate(world, horizon_frames=horizon), at_least=128)
    frames = sorted(e.frame for e in simulate(world, horizon_frames=horizon).events if e.kind == "collision")
    assert any(default_horizon(world) <= f < horizon for f in frames), frames  # the test needs a late collision
    executor = VideoExecutor(tool_client.create_world(world_to_dict(world)))
    names = {0: "red", 1: "blue", 2: "green", 3: "yellow"}
    pairs = list(itertools.combinations(range(4), 2))
    answer = executor.answer_text("Which event will happen next?", [f"The {names[a]} cube collides with the {names[b]} cube" for a, b in pairs])
    assert answer.verdicts == ["correct" if p in future else "wrong" for p in pairs]
    assert {(0, 1), (2, 3)} == future
    continuation = [c for c in executor.world.calls if c.tool == "continue_world"]
    assert len(continuation) == 1 and continuation[0].arguments["horizon_frames"] == horizon
    assert not any(c.tool == "simulate_edit" for c in executor.world.calls)  # no edited (un-anchored) replay
    # Every collision option is corroborated by check_contact on that rollout.
    checks = [c for c in executor.world.calls if c.tool == "check_contact"]
    assert len(checks) == len(pairs)
    assert all(c.arguments["rollout_id"] == continuation[0].digest["rollout_id"] for c in checks)


def test_answers_carry_evidence_that_points_at_real_calls(six):
    answer = six.answer_text("Which of the following will happen if the blue object is removed?", [_pair_text(0, 2), _pair_text(4, 5)])
    calls = six.world.calls
    assert answer.tool_calls and all(0 <= i < len(calls) for i in answer.tool_calls)
    assert [calls[i].tool for i in answer.tool_calls][:2] == ["get_world_summary", "list_events"]
    for choice in answer.choices:
        assert choice.facts, choice
        assert any("check_contact" in f for f in choice.facts)
        assert all(calls[i].tool == "check_contact" for i in choice.tool_calls)
    assert any("removed" in f and "rollout" in f for f in answer.facts)
    document = json.loads(json.dumps(answer.to_dict(calls)))
    assert [c["tool"] for c in document["tool_call_log"]] == [calls[i].tool for i in answer.tool_calls]
    assert [g["status"] for g in document["groundings"]] == ["unique"] * len(document["groundings"])


def test_unparsed_texts_are_reported_not_guessed(six):
    answer = six.answer_text("Why did the red object stop?", ["because"])
    assert answer.verdicts == [None] and "not parsed" in answer.error
    answer = six.answer_text("Which of the following will happen if the blue object is removed?", [_pair_text(0, 2), "The red object flies away"])
    assert answer.verdicts[0] == "correct" and answer.verdicts[1] is None
    assert "not parsed" in answer.choices[1].error


def _record(kind, objects, frame):
    return {"kind": kind, "objects": list(objects), "frame": frame}


@pytest.mark.parametrize(
    "records, expected",
    [
        # A touch reported twice within the debounce window is one collision.
        ([_record("collision", (0, 1), 10), _record("collision", (0, 1), 12)], [("collision", (0, 1), 10)]),
        # Contact again after more than 0.2 s (5 frames at 25 fps) is a new collision.
        ([_record("collision", (0, 1), 10), _record("collision", (0, 1), 16)], [("collision", (0, 1), 10), ("collision", (0, 1), 16)]),
        # A chain of contacts within the window keeps extending it.
        ([_record("collision", (1, 0), 10), _record("collision", (0, 1), 14), _record("collision", (0, 1), 18)], [("collision", (0, 1), 10)]),
        # Other pairs and kinds are independent; stop events are not CLEVRER events; exact duplicates merge.
        ([_record("collision", (0, 1), 10), _record("collision", (1, 2), 11), _record("stop", (0,), 12), _record("in", (3,), 12), _record("in", (3,), 12)],
         [("collision", (0, 1), 10), ("collision", (1, 2), 11), ("in", (3,), 12)]),
    ],
)
def test_clevrer_events_merge_one_touch_into_one_collision(records, expected):
    assert COLLISION_DEBOUNCE_SECONDS == 0.2
    assert [(e.kind, e.objects, e.frame) for e in clevrer_events(records, fps=25.0)] == expected


def test_executor_config_rejects_bad_values():
    with pytest.raises(ValueError, match="mode"):
        ExecutorConfig(mode="guess")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="prediction_horizon_frames"):
        ExecutorConfig(prediction_horizon_frames=0)


def _scripted_world(events: list[dict], objects: list[tuple[int, str, str, str]]):
    """A WorldHandle on an httpx MockTransport serving hand-made tool results (no engine): executor semantics alone."""
    summary = {"fps": 25.0, "observed_frames": 128, "objects": [
        {"object_id": i, "color": c, "material": m, "shape": s, "friction": 0.1} for i, c, m, s in objects]}
    listing = {"events": events, "boundaries": {"horizon_frames": 180, "observed_frames": 128}}

    def handler(request: httpx.Request) -> httpx.Response:
        tool = request.url.path.rsplit("/", 1)[-1]
        if request.method == "GET":
            return httpx.Response(200, json={"world_id": "w-mock"})
        return httpx.Response(200, json={"get_world_summary": summary, "list_events": listing}[tool])

    client = ToolClient("http://mock", transport=httpx.MockTransport(handler))
    return client.world("w-mock")


def test_an_explained_event_occurring_twice_is_decided_by_its_first_occurrence():
    events = [_record("collision", (0, 1), 10), _record("collision", (1, 2), 30), _record("collision", (0, 1), 50),
              _record("in", (3,), 60)]
    world = _scripted_world(events, [(0, "red", "metal", "cube"), (1, "blue", "rubber", "cube"), (2, "green", "metal", "sphere"),
                                     (3, "gray", "rubber", "cylinder")])
    answer = VideoExecutor(world).answer_text(
        "Which of the following is responsible for the collision between the red object and the blue object?",
        ["the presence of the green object", "the presence of the gray object", "the collision between the blue object and the green object"])
    # First occurrence (frame 10) has no causes; the second (frame 50) is caused by c01@10 and c12@30.
    # Every option gets a verdict: the first occurrence decides, the disagreement is stated.
    assert answer.verdicts == ["wrong", "wrong", "wrong"]
    assert "disagree" in answer.choices[0].facts[0] and "uncertain" in answer.choices[0].facts[0]
    assert not any("disagree" in f for f in answer.choices[1].facts)  # both occurrences agree on the gray object
    assert "occurs 2 times" in answer.facts[0]


def test_predictive_answers_continue_from_the_anchored_end_state(tool_client):
    """The anchor turns body 0 towards body 1 at the end of the video; the replay from the
    initial states sends it away. Only the anchored (unedited) continuation predicts the hit."""
    from dataclasses import replace

    from world.io import world_to_dict
    from world.rollout import simulate
    from world.types import Anchor, BodyState

    world = _slow_world()
    moving_away = replace(world.bodies[0], initial=BodyState((-2.0, 0.0, 0.2), (-0.30, 0.0, 0.0)))
    end = 127 / world.fps
    anchored = replace(world, bodies=(moving_away, *world.bodies[1:]),
                       anchor=Anchor(end, ((0, BodyState((-1.0, 0.0, 0.2), (0.5, 0.0, 0.0), time=end)),)))
    horizon = math.ceil(128 * 1.4)
    assert (0, 1) in _collision_pairs(simulate(anchored, horizon_frames=horizon), at_least=128)
    from world.types import Edit
    unanchored = simulate(anchored, [Edit("set_friction", 0, anchored.bodies[0].friction)], horizon_frames=horizon)
    assert (0, 1) not in _collision_pairs(unanchored)  # the old no-op-edit continuation would miss it
    executor = VideoExecutor(tool_client.create_world(world_to_dict(anchored)))
    answer = executor.answer_text("Which event will happen next?", ["The red cube collides with the blue cube"])
    assert answer.verdicts == ["correct"]
    assert not any(c.tool == "simulate_edit" for c in executor.world.calls)


def test_explanatory_answers_come_from_the_observed_collisions(tool_client, six_world):
    """The world's record of the video decides, not the replay: a collision the record lacks is
    no cause even though the replay has it, and the record's own collisions are causes."""
    rollout = simulate(six_world)
    replayed = [(min(e.bodies), max(e.bodies), e.frame) for e in rollout.events
                if e.kind == "collision" and e.frame < six_world.observed_frames]
    assert any(c[:2] == (0, 1) for c in replayed)
    record = tuple(c for c in replayed if c[:2] != (0, 1))
    world = tool_client.create_world(world_to_dict(dataclasses.replace(six_world, observed_collisions=record)))
    executor = VideoExecutor(world)
    question = "Which of the following is responsible for the collision between the yellow object and the purple object?"
    choices = ["the collision between the red object and the blue object", "the collision between the blue object and the green object"]
    answer = executor.answer_text(question, choices)
    assert answer.verdicts == ["wrong", "correct"]
    assert any("record of the video" in fact for fact in answer.facts)
    replay_only = VideoExecutor(tool_client.create_world(world_to_dict(six_world))).answer_text(question, choices)
    assert replay_only.verdicts == ["correct", "correct"]  # the replay alone says otherwise


def test_an_explained_collision_missing_from_the_record_is_decided_from_the_replays_contact(tool_client, six_world):
    """The record of the video lacks the explained collision (3, 4): every option still gets a verdict,
    from the causes of a collision at the replay's contact frame, and the facts say it is uncertain."""
    rollout = simulate(six_world)
    replayed = [(min(e.bodies), max(e.bodies), e.frame) for e in rollout.events
                if e.kind == "collision" and e.frame < six_world.observed_frames]
    contact = next(frame for a, b, frame in replayed if (a, b) == (3, 4))
    record = tuple(c for c in replayed if c[:2] != (3, 4))
    executor = VideoExecutor(tool_client.create_world(world_to_dict(dataclasses.replace(six_world, observed_collisions=record))))
    choices = [f"the presence of the {COLOR[i]} object" for i in range(6)] + ["the collision between the red object and the blue object"]
    answer = executor.answer_text("Which of the following is responsible for the collision between the yellow object and the purple object?", choices)
    others = tuple(EventRecord(e.kind, tuple(e.bodies), e.frame) for e in rollout.events
                   if e.kind in ("in", "out") and e.frame < six_world.observed_frames)
    stand_in = EventRecord("collision", (3, 4), contact)
    scene = ProgramScene(objects=(), events=tuple(sorted(others + tuple(EventRecord("collision", c[:2], c[2]) for c in record) + (stand_in,),
                                                         key=lambda e: (e.frame, e.kind, e.objects))))
    causes = causal_ancestors(scene, stand_in)
    responsible = {o for e in causes for o in e.objects}
    truth = ["correct" if i in responsible else "wrong" for i in range(6)]
    truth.append("correct" if any(e.objects == (0, 1) and e.kind == "collision" for e in causes) else "wrong")
    assert None not in answer.verdicts
    assert answer.verdicts == truth and "correct" in truth and "wrong" in truth
    assert any("uncertain" in fact and f"frame {contact}" in fact for fact in answer.facts)
    assert any(call.tool == "check_contact" for call in executor.world.calls)


def test_an_explained_exit_missing_from_the_video_is_decided_from_the_worlds_later_exit():
    """The world has object 2 leave the view only after the video (frame 140): the question about its exit
    in the video still gets verdicts, from the causes of an exit at the last observed frame, stated uncertain."""
    events = [_record("collision", (0, 1), 10), _record("collision", (1, 2), 30), _record("out", (2,), 140)]
    world = _scripted_world(events, [(0, "red", "metal", "cube"), (1, "blue", "rubber", "cube"), (2, "green", "metal", "sphere"),
                                     (3, "gray", "rubber", "cylinder")])
    answer = VideoExecutor(world).answer_text(
        "Which of the following is responsible for the green object's exit?",
        ["the presence of the red object", "the presence of the gray object", "the collision between the blue object and the green object"])
    assert answer.verdicts == ["correct", "wrong", "correct"]  # exit <- c12@30 <- c01@10; the gray one takes no part
    assert any("uncertain" in fact and "frame 140" in fact and "frame 127" in fact for fact in answer.facts)


def _passing_cubes_world(offset: float):
    """The red cube slides along x past the resting blue one (their sides ``offset - 0.4`` m apart at the closest,
    about 1.6 s after the video); the green one rests 2 m off its path. The engine makes no collision."""
    cube = Shape("cube", half_extent=0.2)
    return World(bodies=(Body(0, cube, BodyState((-2.0, offset, 0.2), (0.30, 0.0, 0.0)), friction=0.001, color="red", material="metal"),
                         Body(1, cube, BodyState((0.0, 0.0, 0.2)), friction=0.001, color="blue", material="rubber"),
                         Body(2, cube, BodyState((0.0, 2.0 + offset, 0.2)), friction=0.001, color="green", material="rubber")),
                 fps=25.0, observed_frames=128, camera=look_at_camera((0.0, -9.0, 6.0), (0.0, 1.0, 0.0)), id="passing")


@pytest.mark.parametrize("offset, expected", [(0.41, "correct"), (0.5, "wrong")])
def test_a_predictive_near_miss_within_the_predictions_spread_is_judged_a_collision(tool_client, offset, expected):
    """The red cube slides past the resting blue one after the video, its side `offset - 0.4` m from the blue
    one's at about frame 167 (1.6 s after the video): 1 cm is inside the continuation's spread there
    (PREDICTION_SPREAD x 1.6 s), 10 cm is not. The engine makes no collision in either case."""
    from planner.executor import PREDICTION_SPREAD

    world = _passing_cubes_world(offset)
    horizon = math.ceil(128 * 1.4)
    assert not _collision_pairs(simulate(world, horizon_frames=horizon))
    assert 0.41 - 0.4 < PREDICTION_SPREAD * 1.5 < 0.5 - 0.4  # the two cases straddle the spread
    executor = VideoExecutor(tool_client.create_world(world_to_dict(world)))
    answer = executor.answer_text("Which event will happen next?", ["The red cube collides with the blue cube"])
    assert answer.verdicts == [expected]
    judged = [f for f in answer.choices[0].facts if "judged a collision" in f]
    assert len(judged) == (expected == "correct") and all("uncertain" in f for f in judged)


@pytest.mark.parametrize("offset", [0.5, 0.8])
def test_which_event_happens_next_picks_the_closest_pair_when_the_continuation_makes_none(tool_client, offset):
    """"Which event will happen next?" presupposes one of its events: when the continuation makes neither
    collision (both pairs miss by more than the prediction's spread), the pair that comes closer is judged to
    happen, stated as uncertain; the other stays wrong."""
    world = _passing_cubes_world(offset)
    assert not _collision_pairs(simulate(world, horizon_frames=math.ceil(128 * 1.4)))
    executor = VideoExecutor(tool_client.create_world(world_to_dict(world)))
    options = ["The red cube collides with the green cube", "The red cube collides with the blue cube"]
    answer = executor.answer_text("Which event will happen next?", options)
    assert answer.verdicts == ["wrong", "correct"]
    judged = [f for f in answer.choices[1].facts if "presupposes" in f]
    assert len(judged) == 1 and "uncertain" in judged[0] and not any("presupposes" in f for f in answer.choices[0].facts)
    reversed_answer = executor.answer_text("Which event will happen next?", options[::-1])
    assert reversed_answer.verdicts == ["correct", "wrong"]  # the evidence decides, not the option's position


def test_which_event_happens_next_keeps_a_single_option_and_a_collision_the_continuation_makes(tool_client):
    """No forced choice with one option (nothing to rank), nor when the continuation makes one of the events."""
    executor = VideoExecutor(tool_client.create_world(world_to_dict(_passing_cubes_world(0.8))))
    assert executor.answer_text("Which event will happen next?", ["The red cube collides with the blue cube"]).verdicts == ["wrong"]
    hit = _passing_cubes_world(0.2)  # the red cube's path crosses the blue one's
    assert (0, 1) in _collision_pairs(simulate(hit, horizon_frames=math.ceil(128 * 1.4)), at_least=128)
    executor = VideoExecutor(tool_client.create_world(world_to_dict(hit)))
    answer = executor.answer_text("Which event will happen next?",
                                  ["The red cube collides with the green cube", "The red cube collides with the blue cube"])
    assert answer.verdicts == ["wrong", "correct"] and not any("presupposes" in f for c in answer.choices for f in c.facts)


def test_a_recorded_collision_the_replay_misses_happens_in_a_counterfactual_that_does_not_touch_its_causes(tool_client, six_world):
    """The record of the video holds two collisions the replay does not make: red-gray at frame 3 (no earlier event
    of either object) and purple-gray at frame 100 (caused through purple's chain 0-1, 1-2, 2-3, 3-4). Removing the
    purple object cannot touch the first, which therefore happens in that counterfactual; removing the red one is
    an ancestor of the second, which the replay decides (no collision)."""
    rollout = simulate(six_world)
    replayed = tuple((min(e.bodies), max(e.bodies), e.frame) for e in rollout.events
                     if e.kind == "collision" and e.frame < six_world.observed_frames)
    assert not any(5 in c[:2] for c in replayed)
    record = tuple(sorted(replayed + ((0, 5, 3), (4, 5, 100)), key=lambda c: c[2]))
    executor = VideoExecutor(tool_client.create_world(world_to_dict(dataclasses.replace(six_world, observed_collisions=record))))
    kept = executor.answer_text("Which of the following will happen if the purple object is removed?",
                                ["The red object collides with the gray object", "The blue object collides with the gray object"])
    assert kept.verdicts == ["correct", "wrong"]
    assert any("kept from the world's record" in fact and "objects 0 and 5" in fact for fact in kept.facts)
    caused = executor.answer_text("Which of the following will happen if the red object is removed?",
                                  ["The purple object collides with the gray object"])
    assert caused.verdicts == ["wrong"]
    replay_only = VideoExecutor(tool_client.create_world(world_to_dict(six_world))).answer_text(
        "Which of the following will happen if the purple object is removed?", ["The red object collides with the gray object"])
    assert replay_only.verdicts == ["wrong"]  # without the record the replay decides
