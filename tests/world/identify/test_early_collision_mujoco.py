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

from bench.pair_mujoco import pair_spec, run_pair
from world.identify.fit import FitConfig, identify
from world.observations import Observations
from world.rollout import simulate
from tests.world.identify.cylinder_tracks import cylinder_track

# (m/s, lateral offset m, the resting one's mass over the mover's)
LAUNCHES = ((2.0, 0.0, 1.0), (1.6, 0.1, 0.5), (2.4, -0.1, 2.0), (1.8, 0.05, 1.0))
LEAD_FRAMES = (3, 4)  # the video begins this many frames before the hit
VIDEO_FRAMES = 40
NOISE_M = 0.005
NOISE_DRAWS = 6  # noise draws per launch and lead
# replay against MuJoCo over the video, both bodies: within twice the tracks' noise on most fits (over 48 fits,
# main 2eab530: 0.50 of them, lead 3 / 4 medians 0.020 / 0.003 m; this rule 0.83, 0.004 / 0.003 m)
CLOSE_M = 2 * NOISE_M
MIN_CLOSE_SHARE = 0.75


def _early_fit(speed: float, offset: float, mass_ratio: float, lead: int, seed: int):
    spec = pair_spec(("cylinder", "cylinder"), speed=speed, offset=offset, frictions=(0.08, 0.08), mass_ratio=mass_ratio)
    truth = run_pair(spec, 2.0)
    hit = min(c.frame for c in truth.collisions)
    first = hit - lead
    assert first > 0, "the launch must be before the video"
    frames = np.arange(VIDEO_FRAMES)
    rng = np.random.default_rng(seed)
    positions = truth.positions[first:first + VIDEO_FRAMES]

    noisy = positions.copy()
    noisy[:, :, :2] += rng.normal(0.0, NOISE_M, (VIDEO_FRAMES, 2, 2))
    tracks = tuple(cylinder_track(body_id, frames, noisy[:, body_id]) for body_id in (0, 1))
    world, _ = identify(Observations(tracks, truth.fps, VIDEO_FRAMES, None), FitConfig())
    replay = simulate(world, (), VIDEO_FRAMES)
    order = [list(replay.body_ids).index(b) for b in (0, 1)]
    error = replay.positions[:, order, :2] - positions[:, :, :2]
    return float(np.sqrt(np.mean(np.sum(error**2, axis=2))))


def test_a_collision_in_the_first_frames_is_replayed():
    rmses = np.array([[[_early_fit(*launch, lead, 100 * draw + k) for k, launch in enumerate(LAUNCHES)]
                       for draw in range(NOISE_DRAWS)] for lead in LEAD_FRAMES])
    share = float(np.mean(rmses < CLOSE_M))
    assert share >= MIN_CLOSE_SHARE, (f"{share:.2f} of the fits within {CLOSE_M} m; median RMSE (m) per lead "
                                      f"{np.round(np.median(rmses, axis=(1, 2)), 4).tolist()}")
