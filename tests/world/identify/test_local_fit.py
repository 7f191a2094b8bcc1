"""Local closed-form slide fits recover the parameters that made a track.

The tracks come from the closed-form flow itself: this checks the optimiser
and the stop handling, not the physics (that is the MuJoCo tests' job).
"""

from __future__ import annotations

import numpy as np
import pytest

from world.identify.local_fit import fit_slide, slide_positions

G = 9.81


@pytest.mark.parametrize(
    "velocity, friction, frames",
    [
        ((2.0, 0.5), 0.3, 40),   # stops inside the window (t_stop ~ 0.70 s)
        ((-1.2, 1.6), 0.15, 30),  # stops near the end
        ((3.0, -1.0), 0.05, 25),  # still coasting at the end
        ((0.8, 0.0), 0.5, 50),    # short slide (4 frames), long rest
    ],
)
def test_fit_recovers_velocity_and_friction(velocity, friction, frames):
    times = np.arange(frames) / 25.0 + 0.4
    start = np.array([0.3, -0.2])
    track = slide_positions(times, times[0], start, np.array(velocity), friction, G)
    fit = fit_slide(times, track, np.ones(frames), G, friction_prior=0.3)
    np.testing.assert_allclose(fit.position, start, atol=1e-4)
    np.testing.assert_allclose(fit.velocity, velocity, rtol=1e-3, atol=1e-3)
    assert fit.friction_identified
    assert fit.friction == pytest.approx(friction, rel=1e-2)
    assert fit.rmse < 1e-4


def test_resting_body_gets_zero_velocity_and_the_prior():
    times = np.arange(20) / 25.0
    noisy = np.array([1.0, 2.0]) + np.random.default_rng(0).normal(0, 0.002, (20, 2))
    fit = fit_slide(times, noisy, np.ones(20), G, friction_prior=0.42)
    np.testing.assert_array_equal(fit.velocity, [0.0, 0.0])
    assert not fit.friction_identified and fit.friction == 0.42
    np.testing.assert_allclose(fit.position, [1.0, 2.0], atol=0.003)


def test_stop_is_exact_and_never_reverses():
    times = np.linspace(0, 3, 301)
    track = slide_positions(times, 0.0, np.zeros(2), np.array([1.0, 0.0]), 0.2, G)
    stop_time = 1.0 / (0.2 * G)
    assert np.all(np.diff(track[:, 0]) >= 0)
    assert track[-1, 0] == pytest.approx(1.0**2 / (2 * 0.2 * G), rel=1e-12)
    assert np.all(track[times >= stop_time, 0] == track[-1, 0])


def test_zero_weights_are_rejected():
    with pytest.raises(ValueError, match="positive weight"):
        fit_slide(np.arange(3.0), np.zeros((3, 2)), np.zeros(3), G, 0.3)
