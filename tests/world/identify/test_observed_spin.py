"""A cube's yaw and yaw rate at the end of the video, read from the yaw its track shows."""

from __future__ import annotations

import math

import numpy as np
import pytest

from world.identify.fit import _observed_spin
from world.observations import ObjectTrack
from world.types import Shape

FPS = 25.0


def _track(yaw_of_time, frames=np.arange(0, 60), unknown=()):
    times = frames / FPS
    yaw = np.array([yaw_of_time(t) for t in times])
    # What a tracker reports: a square's yaw folded into [-pi/4, pi/4), unknown on some frames.
    yaw = (yaw + math.pi / 4) % (math.pi / 2) - math.pi / 4
    yaw[list(unknown)] = np.nan
    n = frames.size
    return ObjectTrack(1, Shape("cube", half_extent=0.2), frames, np.zeros((n, 3)), yaw,
                       np.ones(n, dtype=bool), np.ones(n))


def _same_square_yaw(a, b):
    return abs((a - b + math.pi / 4) % (math.pi / 2) - math.pi / 4)


def test_the_spin_of_the_last_stretch_is_read_through_the_quarter_turn_wraps():
    # Before the collision at frame 30 it does not spin; after it, 4 rad/s decaying at 2 rad/s^2.
    def yaw(t):
        return 0.3 if t < 1.2 else 0.3 + 4.0 * (t - 1.2) - 1.0 * (t - 1.2) ** 2
    got = _observed_spin(_track(yaw, unknown=(50, 51)), breakpoints=(30,), fps=FPS, frame=59)
    t_end = 59 / FPS
    assert got is not None
    assert _same_square_yaw(got[0], yaw(t_end)) < 1e-9
    assert got[1] == pytest.approx(4.0 - 2.0 * (t_end - 1.2), abs=1e-9)


def test_too_few_yaw_samples_after_the_last_collision_give_nothing():
    track = _track(lambda t: 2.0 * t)
    assert _observed_spin(track, breakpoints=(57,), fps=FPS, frame=59) is None
    unknown = _track(lambda t: 2.0 * t, unknown=range(33, 60))
    assert _observed_spin(unknown, breakpoints=(30,), fps=FPS, frame=59) is None
