"""3D lifting of an airborne object from one calibrated camera with the ballistic constraint."""

from __future__ import annotations

import numpy as np
import pytest

from perception.lift3d import ballistic_lift, colour_centres
from world.camera import look_at_camera, project
from world.types import STANDARD_GRAVITY

P0, V0 = np.array([-0.4, 0.05, 0.7]), np.array([2.9, 0.0, 1.7])
TIMES = np.arange(10) / 25.0


def arc(times: np.ndarray) -> np.ndarray:
    return P0 + np.outer(times, V0) + 0.5 * np.outer(times**2, [0.0, 0.0, -STANDARD_GRAVITY])


def test_exact_pixels_give_the_arc_back_in_metres():
    camera = look_at_camera((0.0, -7.0, 3.0), (0.0, 0.0, 0.5))
    lifted = ballistic_lift(camera, TIMES, project(camera, arc(TIMES)))
    assert lifted.p0 == pytest.approx(P0, abs=1e-6) and lifted.v0 == pytest.approx(V0, abs=1e-6)
    assert lifted.rms_ray_distance < 1e-6


def test_pixel_noise_moves_the_arc_along_the_viewing_rays_most():
    camera = look_at_camera((0.0, -7.0, 3.0), (0.0, 0.0, 0.5))
    noisy = project(camera, arc(TIMES)) + np.random.default_rng(5).normal(0.0, 0.3, (len(TIMES), 2))
    lifted = ballistic_lift(camera, TIMES, noisy)
    error = lifted.positions(TIMES) - arc(TIMES)
    along = error @ np.array([0.0, 1.0, 0.0])  # the camera looks along +y
    assert np.sqrt(np.mean(np.sum(error**2, axis=1))) < 0.3  # 0.3 px on a 10-frame arc 7 m away: decimetres in depth
    assert np.sqrt(np.mean(along**2)) > np.sqrt(np.mean(error[:, 0] ** 2))  # depth is the weak direction
    with pytest.raises(ValueError, match="need at least"):
        ballistic_lift(camera, TIMES[:3], noisy[:3])


def test_red_centroid_of_a_painted_disc():
    frames = np.full((2, 40, 60, 3), 120, np.uint8)
    vs, us = np.mgrid[0:40, 0:60]
    frames[0][(us - 20.0) ** 2 + (vs - 10.0) ** 2 <= 16] = (200, 40, 40)
    centres = colour_centres(frames)
    assert centres[0] == pytest.approx([20.0, 10.0], abs=1e-9) and np.all(np.isnan(centres[1]))
