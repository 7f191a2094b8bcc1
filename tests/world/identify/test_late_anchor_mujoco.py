"""The end-of-video state after a collision in the last frames, against MuJoCo (issue 13).

A cylinder at rest is hit 6 frames before the video ends by a body the video
never shows (the generator's MuJoCo model, bench/pair_mujoco.py): no
collision can explain its motion, and its slide fit says it rests. Far away
a cylinder of the same material slides alone (its friction is the struck
one's "similar objects" estimate). The anchored state must be MuJoCo's:
moving at MuJoCo's velocity, so the continuation follows MuJoCo for the
next second.
"""

from __future__ import annotations

import numpy as np
import pytest

from bench.pair_mujoco import lone_spec, pair_spec, run_pair
from world.identify.fit import FitConfig, identify
from world.observations import Observations
from world.rollout import simulate
from tests.world.identify.cylinder_tracks import cylinder_track

FAR = np.array([0.0, 3.0, 0.0])  # m: where the lone cylinder slides (out of reach)

AFTER_HIT = 6  # frames of the video after the hit
AHEAD = 25  # frames of continuation compared (1 s)


@pytest.mark.parametrize("speed, offset", [(1.5, 0.0), (1.3, 0.1)])
def test_a_body_hit_in_the_last_frames_is_anchored_at_mujocos_velocity(speed, offset):
    spec = pair_spec(("cylinder", "cylinder"), speed=speed, offset=offset, frictions=(0.08, 0.08))
    truth = run_pair(spec, 3.0)
    hit = min(c.frame for c in truth.collisions)
    last = hit + AFTER_HIT
    frames = np.arange(last + 1)
    lone = run_pair(lone_spec("cylinder", (1.2, 0.3), 0.08), 3.0)

    tracks = (cylinder_track(1, frames, truth.positions[: last + 1, 1]), cylinder_track(2, frames, lone.positions[: last + 1, 0] + FAR))
    world, _ = identify(Observations(tracks, truth.fps, last + 1, None), FitConfig())
    anchored = dict(world.anchor.states) if world.anchor is not None else {}
    assert 1 in anchored
    mujoco = truth.velocities[last, 1, :2]
    assert np.linalg.norm(np.array(anchored[1].velocity[:2]) - mujoco) < 0.1 * np.linalg.norm(mujoco)
    assert np.linalg.norm(np.array(anchored[1].position[:2]) - truth.positions[last, 1, :2]) < 0.01
    ahead = simulate(world, (), last + AHEAD + 1)
    assert np.linalg.norm(ahead.positions[last + AHEAD, list(ahead.body_ids).index(1), :2] - truth.positions[last + AHEAD, 1, :2]) < 0.05
