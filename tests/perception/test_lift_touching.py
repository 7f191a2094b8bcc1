"""Lifting two touching objects: each centre from its own visible pixels.

Frames are painted in the test (primitives ray-cast with a fixture's camera
over a plain floor, z-buffered, with a shaded lower half as a renderer's dark
side): a sphere touching a cube beside it, and a cylinder touching a sphere
right in front of it (the nearer one hides part of the other). Each object is
segmented and lifted as the pipeline does; its fitted centre must lie within
LIFT_TOLERANCE_M of the truth.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from perception.background import Background
from perception.geometry import primitive_window, ray_depths
from perception.lift import fit_detection
from perception.segment import merge_object_pieces, segment_frame
from world.camera import backproject_to_height, project
from world.io import load_camera
from world.types import CLEVR_PALETTE_RGB

CAMERA = load_camera(Path(__file__).resolve().parents[1] / "data" / "synth" / "ground_truth" / "scene_00000.json")
SIZE = 0.2
FLOOR_RGB = (150, 150, 150)
LIFT_TOLERANCE_M = 0.015  # the 1 cm median target, with room for one frame's pixel quantisation


def _paint(frame, depth, kind, centre, rgb) -> None:
    window = primitive_window(CAMERA, kind, centre, SIZE)
    t = ray_depths(CAMERA, kind, centre, SIZE, 0.0, window)
    region = depth[window.top:window.bottom, window.left:window.right]
    nearer = t < region
    region[nearer] = t[nearer]
    rows = np.mgrid[window.top:window.bottom, window.left:window.right][0]
    middle = rows[np.isfinite(t)].mean()
    colours = np.empty(rows.shape + (3,), np.uint8)
    colours[:] = rgb
    colours[rows > middle] = (np.asarray(rgb) * 0.7).astype(np.uint8)  # the shaded lower half
    frame[window.top:window.bottom, window.left:window.right][nearer] = colours[nearer]


def _background() -> Background:
    image = np.full((CAMERA.height, CAMERA.width, 3), FLOOR_RGB, np.float32)
    return Background(image=image, floor_fit=image.copy(), static=np.zeros((CAMERA.height, CAMERA.width), bool))


def _centre(u: float, v: float) -> np.ndarray:
    return backproject_to_height(CAMERA, np.array([[u, v]]), SIZE)[0]


def _towards_camera(point: np.ndarray, distance: float) -> np.ndarray:
    away = point[:2] - np.asarray(CAMERA.position)[:2]
    return point - np.array([*(away / np.linalg.norm(away) * distance), 0.0])


SIDE_BY_SIDE = [("sphere", "red", _centre(0.45 * CAMERA.width, 0.55 * CAMERA.height)), ("cube", "blue", None)]
IN_FRONT = [("cylinder", "green", _centre(0.4 * CAMERA.width, 0.45 * CAMERA.height)), ("sphere", "yellow", None)]


def _layout(pair):
    (kind_a, colour_a, centre_a), (kind_b, colour_b, _) = pair
    if pair is SIDE_BY_SIDE:
        centre_b = centre_a + np.array([0.0, 2.0 * SIZE + 0.01, 0.0])  # cube face 1 cm from the sphere
    else:
        centre_b = _towards_camera(centre_a, 2.0 * SIZE + 0.01)  # in front, touching
    return [(kind_a, colour_a, centre_a), (kind_b, colour_b, centre_b)]


@pytest.mark.parametrize("pair", [SIDE_BY_SIDE, IN_FRONT], ids=["side by side", "one in front"])
def test_each_of_two_touching_objects_is_lifted_to_its_own_centre(pair):
    objects = _layout(pair)
    frame = np.empty((CAMERA.height, CAMERA.width, 3), np.uint8)
    frame[:] = FLOOR_RGB
    depth = np.full((CAMERA.height, CAMERA.width), np.inf)
    for kind, colour, centre in objects:
        _paint(frame, depth, kind, centre, CLEVR_PALETTE_RGB[colour])
    segments = merge_object_pieces(segment_frame(frame, _background(), 0), CAMERA, SIZE)
    assert len(segments.detections) == 2, "two touching objects of different colours are two segments"
    for kind, colour, centre in objects:
        pixel = project(CAMERA, centre[None])[0]
        detection = min(segments.detections, key=lambda d: np.min(np.hypot(d.xs - pixel[0], d.ys - pixel[1])))
        fit = fit_detection(CAMERA, kind, detection, segments.labels, SIZE)
        error = float(np.linalg.norm(fit.centre[:2] - centre[:2]))
        assert error <= LIFT_TOLERANCE_M, f"{colour} {kind}: {100 * error:.1f} cm from the truth"
