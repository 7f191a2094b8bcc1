"""A coloured object's deep contact shadow is not part of its shape (segment.own_shadow, attributes.shape_overlap).

Under a sun with little fill (Blender's renders) the floor next to an object's base keeps about 0.4 of its
light, darker than background.DARK_OBJECT, so the crescent of shadow that shows below a sphere joins its
segment; a cylinder's silhouette covers the crescent and a sphere's does not, and spheres read as cylinders
(4 of 18 spheres on the Blender development set, seed 7707). The video is painted in the test (a plain floor,
two spheres and a cylinder ray-cast with perception.geometry, each over a hard shadow disc that reaches past
its base towards the camera), h264-encoded as a renderer's would be.
"""

from __future__ import annotations

import numpy as np

from perception.background import DEEP, FLOOR, OBJECT
from perception.pipeline import perceive_frames
from perception.segment import MAX_OWN_SHADOW, body_of, own_shadow
from perception.types import NEUTRAL, Detection
from tests.perception.test_perception_background import CAMERA, _centre_at, _ground_xy, as_decoded, grainy, paint_objects

FRAMES = 40
FLOOR_RGB = np.array([150.0, 150.0, 154.0])  # a plain grey floor (Blender dev seed 7707, scene 7)
SHADOW_RATIO = np.array([0.39, 0.42, 0.46])  # the shadow's light per channel (Blender dev seed 7707, scene 0)
# m: the contact shadow's disc on the floor (the objects' half size is 0.2) and its centre from the object's base
# towards the camera (a light behind the objects): a crescent below each object of 5-20 % of a sphere's segment,
# as on Blender's spheres (a crescent of 20-45 % still reads as a cylinder: docs/perception.md)
SHADOW_RADIUS, TOWARDS_CAMERA = 0.21, 0.03
OBJECTS = (("sphere", "red", (110, 120), (300, 170)), ("cylinder", "green", (380, 110), (250, 230)),
           ("sphere", "purple", (140, 250), (260, 250)))


def _render(seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    ground = _ground_xy()
    camera_xy = np.asarray(CAMERA.position[:2])
    frames = []
    for f in range(FRAMES):
        t = f / (FRAMES - 1)
        centres = [_centre_at(*(np.asarray(a) + t * (np.asarray(b) - np.asarray(a)))) for _, _, a, b in OBJECTS]
        light = np.ones((CAMERA.height, CAMERA.width, 3))
        for centre in centres:
            towards = (camera_xy - centre[:2]) / np.linalg.norm(camera_xy - centre[:2])
            light[np.linalg.norm(ground - (centre[:2] + TOWARDS_CAMERA * towards), axis=-1) < SHADOW_RADIUS] = SHADOW_RATIO
        image = FLOOR_RGB * light
        paint_objects(image, [(kind, colour) for kind, colour, _, _ in OBJECTS], centres)
        frames.append(grainy(image, rng))
    return np.stack(frames)


def test_spheres_over_their_deep_contact_shadow_are_spheres(tmp_path_factory):
    observations, _ = perceive_frames(as_decoded(tmp_path_factory, "contact", _render(seed=5)), CAMERA)
    assert sorted((o.color, o.shape.kind) for o in observations.objects) == [
        ("green", "cylinder"), ("purple", "sphere"), ("red", "sphere")]


def _detection(labels: np.ndarray, hue_label: int) -> Detection:
    ys, xs = np.nonzero(labels != FLOOR)
    return Detection(0, ys.astype(np.int32), xs.astype(np.int32), hue_label, False, 1)


def test_own_shadow_is_a_coloured_segments_deep_part():
    labels = np.full((20, 20), FLOOR, dtype=np.uint8)
    labels[2:12, 4:14] = OBJECT
    labels[12:15, 4:14] = DEEP  # 30 of 130 pixels: a crescent below the body
    coloured = _detection(labels, hue_label=3)
    shadow = own_shadow(labels, coloured)
    assert shadow.sum() == 30 and np.all(coloured.ys[shadow] >= 12)
    assert body_of(coloured, shadow).area == 100
    # a grey segment's body is as deep as its shadow: nothing is told apart
    assert not own_shadow(labels, _detection(labels, hue_label=NEUTRAL)).any()
    # mostly deep: a dark object whose hue is faint, not a shadow
    labels[2:12, 4:14] = DEEP
    labels[2:2 + int(10 * (1 - MAX_OWN_SHADOW)) - 1, 4:14] = OBJECT
    dark = _detection(labels, hue_label=3)
    assert not own_shadow(labels, dark).any() and body_of(dark, own_shadow(labels, dark)) is dark
