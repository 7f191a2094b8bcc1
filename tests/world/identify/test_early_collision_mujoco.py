"""A collision in the video's first frames, against MuJoCo (issue 12 and 13).

A cylinder is launched into a cylinder at rest (the generator's MuJoCo model, bench/pair_mujoco.py) and the video
begins 3 or 4 frames before the hit, so the mover's first stretch (the frames before the contact, less the frame
next to it) holds two or three samples; the tracks carry 5 mm of noise, as perceived ones do. The fit must start
the mover from the direction those samples show: before, a first stretch under three samples took the next
stretch's velocity (the one after the hit, which a head-on hit turns round or stops), and the replay missed the
collision (held-out set 97474, scene 80 from video: the body 2.8 m off).
"""

from __future__ import annotations

import numpy as np
import pytest

from bench.pair_mujoco import pair_spec, run_pair
from world.identify.fit import FitConfig, identify
from world.observations import ObjectTrack, Observations
from world.rollout import simulate
from world.types import Shape

CYLINDER = Shape("cylinder", radius=0.2, half_height=0.2)
# (m/s, lateral offset m, the resting one's mass over the mover's)
LAUNCHES = ((2.0, 0.0, 1.0), (1.6, 0.1, 0.5), (2.4, -0.1, 2.0), (1.8, 0.05, 1.0))
LEAD_FRAMES = (3, 4)  # the video begins this many frames before the hit
VIDEO_FRAMES = 40
NOISE_M = 0.005
# replay against MuJoCo over the video, both bodies: within twice the tracks' noise on most launches (main: median
# 0.023 / 0.015 m for leads 3 / 4, this rule 0.003 / 0.003 m)
MAX_MEDIAN_RMSE_M = 2 * NOISE_M


def _early_fit(speed: float, offset: float, mass_ratio: float, lead: int, seed: int):
    spec = pair_spec(("cylinder", "cylinder"), speed=speed, offset=offset, frictions=(0.08, 0.08), mass_ratio=mass_ratio)
    truth = run_pair(spec, 2.0)
    hit = min(c.frame for c in truth.collisions)
    first = hit - lead
    assert first > 0, "the launch must be before the video"
    frames = np.arange(VIDEO_FRAMES)
    rng = np.random.default_rng(seed)
    positions = truth.positions[first:first + VIDEO_FRAMES]

    def track(body_id: int) -> ObjectTrack:
        noisy = positions[:, body_id].copy()
        noisy[:, :2] += rng.normal(0.0, NOISE_M, (VIDEO_FRAMES, 2))
        return ObjectTrack(body_id, CYLINDER, frames, noisy, np.full(VIDEO_FRAMES, np.nan), np.ones(VIDEO_FRAMES, dtype=bool),
                           np.ones(VIDEO_FRAMES), color="red", material="rubber")

    world, _ = identify(Observations((track(0), track(1)), truth.fps, VIDEO_FRAMES, None), FitConfig())
    replay = simulate(world, (), VIDEO_FRAMES)
    order = [list(replay.body_ids).index(b) for b in (0, 1)]
    error = replay.positions[:, order, :2] - positions[:, :, :2]
    return float(np.sqrt(np.mean(np.sum(error**2, axis=2))))


@pytest.mark.parametrize("lead", LEAD_FRAMES)
def test_a_collision_in_the_first_frames_is_replayed(lead):
    rmses = [_early_fit(*launch, lead, seed) for seed, launch in enumerate(LAUNCHES)]
    assert np.median(rmses) < MAX_MEDIAN_RMSE_M, f"replay RMSE (m) per launch: {np.round(rmses, 3).tolist()}"
