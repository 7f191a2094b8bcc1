"""The record of observed collisions from perceived tracks counts one collision per contact episode, as MuJoCo
does (world.identify.segments.contact_episode_starts): a push through perception's noise gives one pair several
change points while the bodies never separate; a pair that separates and meets again collided twice."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from synth.scene import SceneSpec
from synth.simulate import simulate
from tests.world.identify.test_perceived_tracks import CAMERA, _perceived, _spec
from world.identify.segments import contact_episode_starts, find_candidate_collisions, precise_tracks


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
