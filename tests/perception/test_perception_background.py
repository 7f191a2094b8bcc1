"""The background model calibrates itself on each video: a textured floor and soft, grainy shadows give
no object evidence, so a video over a checker floor gives exactly one track per object.

Videos are painted in the test with a fixture's camera: a high-contrast checker floor on the plane,
spheres and cubes ray-cast (perception.geometry), each with a soft shadow whose penumbra is grainy and
changes from frame to frame (as a ray tracer's sampled area light makes it), h264-encoded as a renderer's
video would be. One object rests the whole video (its shadow, too).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy import ndimage as ndi

from perception.background import AMBIGUOUS, classify_pixels, estimate_background, is_foreground
from perception.geometry import silhouette
from perception.pipeline import perceive_frames
from perception.video import read_video
from synth.render import write_mp4
from world.camera import backproject_to_height
from world.io import load_camera
from world.types import CLEVR_PALETTE_RGB

CAMERA = load_camera(Path(__file__).resolve().parents[1] / "data" / "synth" / "ground_truth" / "scene_00000.json")
SIZE = 0.2
FRAMES = 40
LIGHT_SHIFT = np.array([0.22, 0.16])  # m: a shadow's centre on the floor, from the object's (a low key light)
SHADOW_DEPTH = 0.6  # the shadow core keeps this share of the floor's light (DARK_OBJECT: darker is read as an object)
TILE = 0.5  # m: checker square


def _floor_image(dark: float, light: float) -> np.ndarray:
    """(H, W, 3) float checker floor seen by the camera (squares of TILE m, slightly warm)."""
    v, u = np.mgrid[0:CAMERA.height, 0:CAMERA.width]
    points = backproject_to_height(CAMERA, np.stack([u.ravel() + 0.5, v.ravel() + 0.5], axis=1).astype(float), 0.0)
    squares = (np.floor(points[:, 0] / TILE) + np.floor(points[:, 1] / TILE)) % 2
    grey = np.where(squares == 1, light, dark).reshape(CAMERA.height, CAMERA.width)
    return grey[..., None] * np.array([1.0, 0.97, 0.92])


def _ground_xy() -> np.ndarray:
    """(H, W, 2) floor coordinates (m) of every pixel."""
    v, u = np.mgrid[0:CAMERA.height, 0:CAMERA.width]
    points = backproject_to_height(CAMERA, np.stack([u.ravel() + 0.5, v.ravel() + 0.5], axis=1).astype(float), 0.0)
    return points[:, :2].reshape(CAMERA.height, CAMERA.width, 2)


def _centre_at(u: float, v: float) -> np.ndarray:
    return backproject_to_height(CAMERA, np.array([[u, v]], float), SIZE)[0]


# (kind, colour, start pixel, end pixel): two moving objects and one resting the whole video
OBJECTS = (
    ("sphere", "red", (120, 150), (300, 200)),
    ("cube", "blue", (360, 120), (220, 250)),
    ("sphere", "yellow", (200, 90), (200, 90)),
)


def paint_objects(image: np.ndarray, objects: list[tuple[str, str]], centres: list[np.ndarray]) -> np.ndarray:
    """Ray-cast (kind, colour) primitives at ``centres`` into the (H, W, 3) float ``image`` in place, nearest in front,
    lit from above; returns (H, W) bool where an object is."""
    covered = np.zeros(image.shape[:2], dtype=bool)
    depth = np.full(image.shape[:2], np.inf)
    for (kind, colour), centre in zip(objects, centres):
        window, mask = silhouette(CAMERA, kind, centre, SIZE, 0.3)
        distance = np.linalg.norm(centre - np.asarray(CAMERA.position))
        region = (slice(window.top, window.top + mask.shape[0]), slice(window.left, window.left + mask.shape[1]))
        paint = mask & (distance < depth[region])
        rows = np.linspace(1.15, 0.7, mask.shape[0])[:, None, None]  # lit from above
        image[region][paint] = (np.asarray(CLEVR_PALETTE_RGB[colour], float) * rows * np.ones((1, mask.shape[1], 1)))[paint]
        depth[region][paint] = distance
        covered[region] |= mask
    return covered


def _render(seed: int) -> tuple[np.ndarray, np.ndarray]:
    """(FRAMES, H, W, 3) uint8 frames of OBJECTS over the checker floor with grainy soft shadows, and
    (FRAMES, H, W) bool: where an object or its shadow is."""
    rng = np.random.default_rng(seed)
    floor = _floor_image(95.0, 185.0)
    ground = _ground_xy()
    frames, touched = [], []
    for f in range(FRAMES):
        t = f / (FRAMES - 1)
        light = np.ones((CAMERA.height, CAMERA.width))
        centres = [_centre_at(*(np.asarray(a) + t * (np.asarray(b) - np.asarray(a)))) for _, _, a, b in OBJECTS]
        for centre in centres:  # soft shadow: a disc on the floor with a wide penumbra, sampled grain in it
            distance = np.linalg.norm(ground - (centre[:2] + LIGHT_SHIFT), axis=-1)
            occlusion = np.clip((0.32 - distance) / 0.14, 0.0, 1.0)
            penumbra = (occlusion > 0) & (occlusion < 1)
            occlusion = np.where(penumbra, np.clip(occlusion + rng.normal(0, 0.12, occlusion.shape), 0, 1), occlusion)
            light = np.minimum(light, 1.0 - (1.0 - SHADOW_DEPTH) * occlusion)
        image = floor * light[..., None]
        touched.append((light < 1.0) | paint_objects(image, [(kind, colour) for kind, colour, _, _ in OBJECTS], centres))
        frames.append(grainy(image, rng))
    return np.stack(frames), np.stack(touched)


def grainy(image: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """(H, W, 3) uint8 of a float image with 1 grey level of sensor noise."""
    return np.clip(image + rng.normal(0, 1.0, image.shape), 0, 255).astype(np.uint8)


def as_decoded(tmp_path_factory, name: str, frames: np.ndarray) -> np.ndarray:
    """(F, H, W, 3) uint8 frames h264-encoded, as a renderer's would be, and decoded back."""
    path = tmp_path_factory.mktemp(name) / f"{name}.mp4"
    write_mp4(path, frames, 25.0, crf=23)  # the generator's encoder: the same frames give the same video every run
    return read_video(path)[0]


@pytest.fixture(scope="module")
def checker_video(tmp_path_factory) -> tuple[np.ndarray, np.ndarray]:
    path = tmp_path_factory.mktemp("checker") / "checker.mp4"
    frames, touched = _render(seed=5)
    write_mp4(path, frames, 25.0, crf=23)
    decoded, _ = read_video(path)
    return decoded, touched


def test_checker_floor_gives_no_object_evidence(checker_video):
    """Away from the objects and their shadows (3 px margin), no pixel of the textured floor is object evidence."""
    frames, touched = checker_video
    background = estimate_background(frames)
    floor_pixels, objects = 0, 0
    for f in range(0, FRAMES, 5):
        far = ~ndi.binary_dilation(touched[f], iterations=3)
        floor_pixels += int(far.sum())
        objects += int(is_foreground(classify_pixels(frames[f], background)[far]).sum())
    assert objects < 1e-3 * floor_pixels, f"{objects} of {floor_pixels} checker floor pixels away from the objects are object evidence"


@pytest.mark.slow
def test_checker_floor_with_grainy_soft_shadows_gives_one_track_per_object(checker_video):
    observations, _ = perceive_frames(checker_video[0], CAMERA)
    kinds = sorted((o.shape.kind, o.color) for o in observations.objects)
    assert len(observations.objects) == len(OBJECTS), f"{len(observations.objects)} tracks for {len(OBJECTS)} objects: {kinds}"
    assert sorted(o.color for o in observations.objects) == sorted(c for _, c, _, _ in OBJECTS)


def test_shadow_of_a_resting_object_is_not_an_object_once_it_leaves():
    """A pixel shadowed in most frames (an object resting, then leaving) gets the lit floor as background:
    its shadow's ghost is no object evidence in the frames after the object left."""
    floor = _floor_image(95.0, 185.0).astype(np.float32)
    frames = np.repeat(floor[None], 25, axis=0)
    shadow = np.zeros(floor.shape[:2], bool)
    shadow[100:160, 200:300] = True
    frames[:18, shadow] *= SHADOW_DEPTH  # shadowed for 18 of 25 frames, then lit
    frames = frames.astype(np.uint8)
    background = estimate_background(frames)
    labels = classify_pixels(frames[-1], background)
    assert int(is_foreground(labels).sum()) == 0
    assert not bool(background.static[shadow].any())
    # while the shadow was there it is shadow-like (ambiguous), never an object
    assert int(is_foreground(classify_pixels(frames[0], background)[shadow]).sum()) == 0
    assert int((classify_pixels(frames[0], background)[shadow] == AMBIGUOUS).sum()) > 0.9 * shadow.sum()


def test_a_resting_objects_place_shows_the_floor_seen_there_before_it_came():
    """A pixel an object rests on in most frames (its median is the object, not floor) gets the floor the video
    showed there before the object came, not the smooth floor model: on a checker floor the model is mid-grey,
    so the squares there would be object evidence in the frames before the object arrived."""
    floor = _floor_image(95.0, 185.0)
    frames = np.repeat(floor[None], 25, axis=0)
    resting = np.zeros(floor.shape[:2], bool)
    for f in range(7, 25):  # arrives at frame 7 and stays: 18 of 25 frames
        resting |= paint_objects(frames[f], [("sphere", "red")], [_centre_at(200, 150)])
    frames = np.clip(frames + np.random.default_rng(3).normal(0, 1.0, frames.shape), 0, 255).astype(np.uint8)
    background = estimate_background(frames)
    assert bool(background.static[resting].mean() > 0.9)  # the median there is the object
    for f in range(7):
        assert int(is_foreground(classify_pixels(frames[f], background)[resting]).sum()) == 0
    # while it rests there it is an object
    assert float(is_foreground(classify_pixels(frames[-1], background)[resting]).mean()) > 0.9


def test_a_resting_objects_place_on_a_flat_floor_is_the_smooth_floor_model():
    """On a flat floor (no texture sets the static threshold) a resting object's place keeps the smooth model:
    the model is the floor there, and the samples around the object's edge are no better."""
    floor = np.full((CAMERA.height, CAMERA.width, 3), 150.0) * np.array([1.0, 0.97, 0.92])
    frames = np.repeat(floor[None], 25, axis=0)
    resting = np.zeros(floor.shape[:2], bool)
    for f in range(7, 25):
        resting |= paint_objects(frames[f], [("sphere", "red")], [_centre_at(200, 150)])
    frames = np.clip(frames + np.random.default_rng(3).normal(0, 1.0, frames.shape), 0, 255).astype(np.uint8)
    background = estimate_background(frames)
    assert bool(background.static[resting].mean() > 0.9)
    np.testing.assert_array_equal(background.image[background.static], background.floor_fit[background.static])
