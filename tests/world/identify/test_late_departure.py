"""The anchor after a collision in the last frames of the video (issue 13, +3 s error).

The change points need 6 frames after a contact to see it; a body hit in the
last frames kept the slide of its whole last stretch (at rest, or its old
velocity) as its end-of-video state. local_fit.late_departure finds the tail
that left that slide, local_fit.tail_state reads the new motion from it.
"""

from __future__ import annotations

import numpy as np
import pytest

from world.identify.fit import TrackFit, _seen_motion
from world.identify.local_fit import fit_slide, late_departure, slide_positions, tail_state
from world.observations import ObjectTrack
from world.types import STANDARD_GRAVITY, Shape

FPS = 25.0
G = STANDARD_GRAVITY


def _slide_then_hit(hit_frame: int, last: int = 127, noise: float = 0.0, seed: int = 0):
    """(frames, positions (T, 2)) of a body resting at (1, 2) hit at ``hit_frame`` to 1.2 m/s at mu 0.1."""
    frames = np.arange(60, last + 1)
    times = frames / FPS
    positions = np.tile([1.0, 2.0], (frames.size, 1))
    after = frames >= hit_frame
    positions[after] = slide_positions(times[after], hit_frame / FPS, np.array([1.0, 2.0]), np.array([-0.9, 0.8]), 0.1, G)
    rng = np.random.default_rng(seed)
    return frames, positions + rng.normal(0.0, noise, positions.shape)


@pytest.mark.parametrize("hit_frame", [118, 121, 123])
def test_a_hit_in_the_last_frames_is_found_and_its_velocity_read(hit_frame):
    frames, positions = _slide_then_hit(hit_frame)
    times = frames / FPS
    stretch = fit_slide(times, positions, np.ones(frames.size), G, 0.1)
    cut = late_departure(times, positions, stretch, G)
    assert cut is not None and frames[cut] in (hit_frame + 1, hit_frame + 2)
    position, velocity = tail_state(times[cut:], positions[cut:], 0.1, G, times[-1])
    speed_then = np.hypot(0.9, 0.8) - 0.1 * G * (times[-1] - hit_frame / FPS)
    truth_velocity = np.array([-0.9, 0.8]) / np.hypot(0.9, 0.8) * speed_then
    assert np.linalg.norm(position - positions[-1]) < 1e-3
    assert np.linalg.norm(velocity - truth_velocity) < 0.02


@pytest.mark.parametrize("seed", range(10))
def test_a_plain_noisy_slide_has_no_departure(seed):
    # 3 % of a 0.4 m object per coordinate, bench_identify's strongest noise.
    frames = np.arange(40, 128)
    times = frames / FPS
    clean = slide_positions(times, times[0], np.array([0.0, 0.0]), np.array([1.5, -0.4]), 0.08, G)
    noisy = clean + np.random.default_rng(seed).normal(0.0, 0.012, clean.shape)
    stretch = fit_slide(times, noisy, np.ones(frames.size), G, 0.1)
    assert late_departure(times, noisy, stretch, G) is None


def test_too_short_a_tail_is_left_to_the_replay():
    frames, positions = _slide_then_hit(125)
    times = frames / FPS
    stretch = fit_slide(times, positions, np.ones(frames.size), G, 0.1)
    assert late_departure(times, positions, stretch, G) is None


def test_the_anchor_takes_the_tail_and_a_two_sample_stretch_only_when_the_replay_is_elsewhere():
    frames, positions = _slide_then_hit(121)
    n = frames.size
    track = ObjectTrack(3, Shape("cylinder", radius=0.2, half_height=0.2), frames, np.c_[positions, np.full(n, 0.2)],
                        np.full(n, np.nan), np.ones(n, dtype=bool), np.ones(n))
    stretch = fit_slide(frames[:-1] / FPS, positions[:-1], np.ones(n - 1), G, 0.1)
    (position, velocity), breakpoints = _seen_motion(TrackFit(track, (stretch,), ()), 0.1, positions[-1], FPS, 127, G)
    assert np.hypot(*velocity) > 0.8  # the slide alone says: at rest
    assert breakpoints and breakpoints[-1] >= 121
    two = fit_slide(frames[-2:] / FPS, positions[-2:], np.ones(2), G, 0.1)
    fit = TrackFit(track, (stretch, two), (125,))
    assert _seen_motion(fit, 0.1, positions[-1] + [0.01, 0.0], FPS, 127, G) is None
    (position, velocity), _ = _seen_motion(fit, 0.1, positions[-1] + [0.2, 0.0], FPS, 127, G)
    assert np.linalg.norm(position - positions[-1]) < 1e-3 and np.hypot(*velocity) > 0.8
