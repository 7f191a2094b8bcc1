"""Laws of the camera geometry used for lifting."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from perception.geometry import silhouette
from world.camera import backproject_to_height
from world.camera import project
from world.io import load_camera

CAMERA = load_camera(Path(__file__).resolve().parents[1] / "data" / "synth" / "ground_truth" / "scene_00000.json")


@settings(max_examples=60, deadline=None)
@given(st.floats(20, 460), st.floats(20, 300), st.floats(0.0, 0.6))
def test_backprojection_inverts_projection(u, v, height):
    point = backproject_to_height(CAMERA, np.array([[u, v]]), height)[0]
    assert abs(point[2] - height) < 1e-9
    assert np.allclose(project(CAMERA, point), [u, v], atol=1e-6)


@pytest.mark.parametrize("kind", ["sphere", "cube", "cylinder"])
@pytest.mark.parametrize("xy", [(-1.0, 0.5), (0.0, 1.0), (1.2, 2.0)])
def test_silhouette_is_centred_on_the_projected_centre(kind, xy):
    centre = np.array([xy[0], xy[1], 0.2])
    window, mask = silhouette(CAMERA, kind, centre, 0.2, 0.3)
    ys, xs = np.nonzero(mask)
    u, v = project(CAMERA, centre)
    # A convex solid's silhouette surrounds its centre's projection (perspective shifts it a little).
    assert abs(xs.mean() + window.left - u) < 3 and abs(ys.mean() + window.top - v) < 3
    assert mask.sum() > 300


def test_silhouette_grows_when_nearer_to_the_camera():
    far = silhouette(CAMERA, "sphere", np.array([0.0, 2.0, 0.2]), 0.2)[1].sum()
    near = silhouette(CAMERA, "sphere", np.array([0.0, -0.5, 0.2]), 0.2)[1].sum()
    assert near > far * 1.2
