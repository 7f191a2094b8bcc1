"""Re-anchoring of the factual continuation, and contact episodes."""

from __future__ import annotations

import numpy as np
import pytest

from world.io import validate_world_dict, world_from_dict, world_to_dict
from world.rollout import merge_contact_episodes, simulate
from world.types import Anchor, Body, BodyState, Edit, Event, Shape, World

CYLINDER = Shape("cylinder", radius=0.2, half_height=0.2)


def _world(anchor: Anchor | None) -> World:
    bodies = (
        Body(0, CYLINDER, BodyState((0.0, 0.0, 0.2), (1.0, 0.0, 0.0)), mass=1.0, friction=0.05),
        Body(1, CYLINDER, BodyState((0.0, 3.0, 0.2)), mass=1.0, friction=0.05),
    )
    return World(bodies, fps=25.0, observed_frames=50, anchor=anchor)


def test_base_rollout_continues_from_the_anchor_state():
    anchor = Anchor(1.0, ((0, BodyState((2.0, 0.5, 0.2), (0.0, 1.0, 0.0), time=1.0)),))
    rollout = simulate(_world(anchor), horizon_frames=60)
    plain = simulate(_world(None), horizon_frames=60)
    # Before the anchor: identical to the un-anchored replay.
    np.testing.assert_allclose(rollout.positions[:25], plain.positions[:25])
    # From the anchor frame on: the closed-form slide from the anchor state.
    tau = rollout.times[25:] - 1.0
    expected_y = 0.5 + 1.0 * tau - 0.5 * 0.05 * 9.81 * tau**2
    np.testing.assert_allclose(rollout.positions[25:, 0, 0], 2.0)
    np.testing.assert_allclose(rollout.positions[25:, 0, 1], expected_y, atol=1e-12)


def test_edited_rollouts_ignore_the_anchor():
    anchor = Anchor(1.0, ((0, BodyState((2.0, 0.5, 0.2), (0.0, 1.0, 0.0), time=1.0)),))
    edit = (Edit("set_mass", 1, 2.0),)  # does not touch body 0's motion
    edited = simulate(_world(anchor), edit, horizon_frames=60)
    plain = simulate(_world(None), horizon_frames=60)
    np.testing.assert_allclose(edited.positions[:, 0], plain.positions[:, 0])


def test_removing_an_anchored_body_keeps_the_world_valid():
    anchor = Anchor(1.0, ((0, BodyState((2.0, 0.5, 0.2), time=1.0)), (1, BodyState((0.0, 3.0, 0.2), time=1.0))))
    rollout = simulate(_world(anchor), (Edit("remove_object", 0),), horizon_frames=30)
    assert rollout.body_ids == (1,)


def test_anchor_round_trips_through_json():
    anchor = Anchor(1.0, ((1, BodyState((0.1, 3.0, 0.2), (0.3, 0.0, 0.0), yaw=0.4, time=1.0)),))
    document = world_to_dict(_world(anchor))
    validate_world_dict(document)
    assert world_from_dict(document).anchor == anchor


def test_anchor_naming_an_unknown_body_is_rejected():
    with pytest.raises(ValueError, match="anchor.states: unknown body id 7"):
        _world(Anchor(1.0, ((7, BodyState((0.0, 0.0, 0.2), time=1.0)),)))


def _collision(pair, time, impulse=1.0):
    return Event("collision", pair, time, round(time * 25), (0.0, 0.0, 0.0), impulse)


@pytest.mark.parametrize(
    "times, kept",
    [
        ([0.0, 0.05, 0.1], [0.0]),  # a rattle: one episode
        ([0.0, 0.3], [0.0, 0.3]),  # two separate hits
        ([0.0, 0.15, 0.3, 0.6], [0.0, 0.6]),  # an episode grows while impulses keep coming
    ],
)
def test_contact_episodes_merge_a_pairs_close_collisions(times, kept):
    merged = merge_contact_episodes([_collision((0, 1), t) for t in times])
    assert [e.time for e in merged] == kept
    assert sum(e.impulse for e in merged) == pytest.approx(len(times))


def test_contact_episodes_keep_other_pairs_and_kinds():
    events = [_collision((0, 1), 0.0), Event("stop", (2,), 0.01, 0), _collision((1, 2), 0.02), _collision((0, 1), 0.05)]
    merged = merge_contact_episodes(events)
    assert [(e.kind, e.bodies) for e in merged] == [("collision", (0, 1)), ("stop", (2,)), ("collision", (1, 2))]


def test_contact_episode_ends_only_after_the_pair_is_apart_for_the_gap():
    # The callback says whether the pair was apart for the gap between two collisions.
    hits = [_collision((0, 1), 0.0), _collision((0, 1), 0.5)]
    assert len(merge_contact_episodes(hits, apart=lambda pair, t0, t1: False)) == 1  # kept touching: one collision
    assert len(merge_contact_episodes(hits, apart=lambda pair, t0, t1: True)) == 2


def _catch_up(restitution: float) -> World:
    """A light-friction body hits a high-friction one head-on, separates, and catches it up again."""
    bodies = (
        Body(0, CYLINDER, BodyState((0.0, 0.0, 0.2), (2.0, 0.0, 0.0)), mass=1.0, friction=0.05, restitution=restitution),
        Body(1, CYLINDER, BodyState((1.0, 0.0, 0.2)), mass=1.0, friction=0.3, restitution=restitution),
    )
    return World(bodies, fps=25.0, observed_frames=100)


def test_a_pair_that_barely_separates_is_one_collision(monkeypatch):
    import world.rollout as rollout_module

    def collisions(world):
        return [e.time for e in simulate(world, horizon_frames=150).events if e.kind == "collision"]

    # e = 0.2: the pair opens ~3 cm for ~0.3 s, then meets again: two collisions.
    assert len(collisions(_catch_up(0.2))) == 2
    # e = 0.14: the pair is never 2 mm apart for 0.2 s: one contact episode, though the
    # impulses are 0.21 s apart (the old rule, time since the last impulse, split it).
    merged = collisions(_catch_up(0.14))
    monkeypatch.setattr(rollout_module, "_apart_for_gap", lambda world, logs, pair, t0, t1: t1 - t0 > rollout_module.CONTACT_EPISODE_GAP)
    split = collisions(_catch_up(0.14))
    assert len(merged) == 1 and len(split) >= 2
