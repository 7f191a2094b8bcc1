"""The record of observed collisions from perceived tracks counts one collision per contact episode, as MuJoCo
does (world.identify.segments.contact_episode_starts): a push through perception's noise gives one pair several
change points while the bodies never separate; a pair that separates and meets again collided twice; an
episode's start whose evidence is one-sided does not take its corroborated collision out of the record."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from synth.scene import SceneSpec
from synth.simulate import simulate
from tests.world.identify.test_perceived_tracks import CAMERA, _perceived, _spec
from world.identify.fit import recorded_collisions
from world.identify.segments import CandidateCollision, contact_episode_starts, find_candidate_collisions, precise_tracks
from world.observations import ObjectTrack, Observations, default_shape


def _collisions(result, pair) -> list[int]:
    return [e.frame for e in result.events if e.kind == "collision" and tuple(sorted(e.bodies)) == pair]


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_a_push_is_one_collision_through_perceptions_noise(seed):
    # a heavy cube runs into a light one and pushes it (restitution 0.05): MuJoCo counts one collision
    pusher = replace(_spec(0, "cube", (-1.2, 0.0), (2.5, 0.0), 200.0), restitution=0.05)
    pushed = replace(_spec(1, "cube", (-0.2, 0.0), (0.0, 0.0), 20.0), restitution=0.05)
    result = simulate(SceneSpec(0, CAMERA, (pusher, pushed), observed_frames=60, future_frames=0))
    (hit,) = _collisions(result, (0, 1))
    observations = _perceived(result, (0, 1), ("cube", "cube"), seed, {})
    assert not precise_tracks(observations)
    candidates = find_candidate_collisions(observations)
    (kept,) = contact_episode_starts(candidates, observations, precise_tracks(observations))
    assert abs(kept.frame - hit) <= 4
    if seed == 2:
        assert len(candidates) > 1  # the noise made several change points of the push (the rule is exercised)


def _bounce_back():
    """MuJoCo: a sphere hits another (e 0.9), which bounces off a heavy cube back into the first one."""
    first = replace(_spec(0, "sphere", (-1.4, 0.0), (3.0, 0.0), 20.0), restitution=0.9)
    second = replace(_spec(1, "sphere", (-0.6, 0.0), (0.0, 0.0), 20.0), restitution=0.9)
    wall = replace(_spec(0, "cube", (0.4, 0.0), (0.0, 0.0), 800.0), object_id=2, color="green", restitution=0.9)
    return simulate(SceneSpec(0, CAMERA, (first, second, wall), observed_frames=70, future_frames=0))


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_a_pair_that_separates_and_meets_again_collided_twice(seed):
    result = _bounce_back()
    hits = _collisions(result, (0, 1))
    assert len(hits) == 2
    observations = _perceived(result, (0, 1, 2), ("sphere", "sphere", "cube"), seed, {})
    kept = [c.frame for c in contact_episode_starts(find_candidate_collisions(observations), observations, precise_tracks(observations)) if c.bodies == (0, 1)]
    assert len(kept) == 2 and all(abs(k - h) <= 3 for k, h in zip(kept, hits))


def test_precise_tracks_keep_their_touch_episodes():
    # oracle-like tracks (no noise): touches are counted by geometry already, the rule leaves them alone
    result = _bounce_back()
    observations = _perceived(result, (0, 1, 2), ("sphere", "sphere", "cube"), 0, {})
    exact = replace(observations, objects=tuple(replace(t, positions=np.round(result.positions[t.frames, k], 4))
                                                for k, t in enumerate(observations.objects)))
    assert precise_tracks(exact) == {0, 1, 2}
    candidates = find_candidate_collisions(exact)
    assert contact_episode_starts(candidates, exact, precise_tracks(exact)) == sorted(candidates, key=lambda c: (c.frame, c.bodies))


def _resting(object_id: int, kind: str, xs: np.ndarray) -> ObjectTrack:
    """A body's track over len(xs) frames at (xs[k], 0) m (yaw 0), perceived-like weights."""
    shape = default_shape(kind)
    positions = np.column_stack([xs, np.zeros(xs.size), np.full(xs.size, shape.rest_height)])
    return ObjectTrack(object_id, shape, np.arange(xs.size), positions, np.zeros(xs.size), np.ones(xs.size, bool),
                       np.full(xs.size, 0.6))


def _candidate(frame: int, corroborated: bool) -> CandidateCollision:
    return CandidateCollision((0, 1), frame, np.zeros((2, 2)), np.zeros((2, 2)), np.array([1.0, 0.0]), corroborated)


def test_a_one_sided_start_the_replay_does_not_make_leaves_the_episode_its_corroborated_collision():
    """fit.recorded_collisions: a one-sided candidate (another body's impulse read on a touching pair) opens a
    contact episode, and the pair's corroborated collision follows in it. When the replay does not make the
    first, the record keeps the second (main before: the episode's start stood for it and was then dropped,
    taking the collision with it); when the replay makes the first, the first stands for the episode."""
    frames = 40
    spheres = Observations((_resting(0, "sphere", np.zeros(frames)), _resting(1, "sphere", np.full(frames, 0.41))), 25.0, frames, None)
    candidates = [_candidate(10, False), _candidate(20, True)]
    assert recorded_collisions(candidates, spheres, frozenset(), replayed=[]) == ((0, 1, 20),)
    assert recorded_collisions(candidates, spheres, frozenset(), replayed=[(0, 1, 11)]) == ((0, 1, 11),)  # at the replay's frame


@pytest.mark.parametrize("replayed, precise, recorded", [
    ([(0, 1, 22)], frozenset(), ((0, 1, 22),)),  # the replay's frame: the change point at 20 read early
    ([(0, 1, 19), (0, 1, 22)], frozenset(), ((0, 1, 19),)),  # the closest of the pair's replayed collisions
    ([(0, 1, 26)], frozenset(), ((0, 1, 20),)),  # beyond the contact-episode gap (5 frames at 25 fps): another collision
    ([(0, 2, 21)], frozenset(), ((0, 1, 20),)),  # another pair
    ([(0, 1, 22)], frozenset({0}), ((0, 1, 22),)),  # one precise track: still the replay's
    ([(0, 1, 22)], frozenset({0, 1}), ((0, 1, 20),)),  # two precise tracks: their own change point
])
def test_a_recorded_collision_of_noisy_tracks_takes_the_frame_of_the_replay_s_collision(replayed, precise, recorded):
    """fit.recorded_collisions: for noisy tracks the track analysis says which pairs collide and the fitted
    replay when (a change point lands a frame or two early where a track is lost before the contact)."""
    frames = 40
    spheres = Observations((_resting(0, "sphere", np.zeros(frames)), _resting(1, "sphere", np.full(frames, 0.41))), 25.0, frames, None)
    assert recorded_collisions([_candidate(20, True)], spheres, precise, replayed=replayed) == recorded
