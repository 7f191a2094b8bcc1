"""Shadows cast by one distant light (perception.shadows): the closed forms against marching towards the light,
the light calibrated on a video from its coloured objects, and a grey object lifted with the deep shadow its
segment holds (Blender's sun leaves about 0.4 of the floor's light in a hard shadow: as deep as a grey object).

The video is painted in the test: a plain warm floor, two coloured objects and a grey cube, each with a hard
shadow found by marching from every floor pixel towards the light (not by the closed forms under test).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from perception.geometry import silhouette
from perception.pipeline import perceive_frames
from perception.segment import ClassicalSegmenter
from perception.shadows import ShadowSample, estimate_reach, in_shadow, reach_of, shadow_sample
from tests.perception.test_perception_background import CAMERA, SIZE, _centre_at, _ground_xy, as_decoded, grainy, paint_objects
from tests.perception.test_perception_deep_shadows import FLOOR_RGB, SHADOW_RATIO  # Blender's warm floor and hard shadow

HEIGHTS = 81  # marching steps from the floor to the top of a primitive


def _inside(kind: str, yaw: float, points: np.ndarray) -> np.ndarray:
    """(...,) bool: points (..., 3) relative to the primitive's centre (at height SIZE) lie inside it."""
    x, y, z = points[..., 0], points[..., 1], points[..., 2]
    if kind == "sphere":
        return x * x + y * y + z * z <= SIZE * SIZE
    if kind == "cylinder":
        return (x * x + y * y <= SIZE * SIZE) & (np.abs(z) <= SIZE)
    c, s = math.cos(yaw), math.sin(yaw)
    return (np.abs(c * x + s * y) <= SIZE) & (np.abs(-s * x + c * y) <= SIZE) & (np.abs(z) <= SIZE)


def _marched_shadow(kind: str, yaw: float, offsets: np.ndarray, reach: np.ndarray) -> np.ndarray:
    """(...,) bool: the line from each floor point (offsets (..., 2) from the centre) towards the light meets the
    primitive at one of HEIGHTS heights."""
    shadowed = np.zeros(offsets.shape[:-1], dtype=bool)
    for h in np.linspace(0.0, 2 * SIZE, HEIGHTS):
        point = np.concatenate([offsets - h * reach, np.full(offsets.shape[:-1] + (1,), h - SIZE)], axis=-1)
        shadowed |= _inside(kind, yaw, point)
    return shadowed


@pytest.mark.parametrize("kind", ["sphere", "cylinder", "cube"])
def test_closed_form_shadows_match_marching_towards_the_light(kind):
    rng = np.random.default_rng(3)
    for _ in range(6):
        reach = reach_of(rng.uniform(0, 2 * math.pi), math.radians(rng.uniform(25, 85)))
        yaw = float(rng.uniform(0, math.pi / 2))
        offsets = rng.uniform(-1.2, 1.2, (4000, 2))
        closed, marched = in_shadow(kind, SIZE, yaw, offsets, reach), _marched_shadow(kind, yaw, offsets, reach)
        assert marched.sum() > 50  # the shadow is in the sampled square
        assert np.mean(closed != marched) < 0.003, f"{kind}: {np.sum(closed != marched)} of 4000 points disagree"


FRAMES = 40
AZIMUTH, ELEVATION = math.radians(210.0), math.radians(40.0)  # the light comes from there
REACH = reach_of(AZIMUTH, ELEVATION)
# (kind, colour, start pixel, end pixel); paint_objects gives cubes the yaw 0.3
OBJECTS = (("sphere", "red", (60, 120), (260, 150)), ("cylinder", "blue", (360, 90), (440, 180)),
           ("cube", "gray", (120, 240), (300, 260)))
CUBE_YAW = 0.3
NOISE_SEEDS = (23, 24, 25, 26, 27, 28)  # the same scene under six draws of sensor noise (one h264 encoding each)


def _poses() -> list[list[np.ndarray]]:
    return [[_centre_at(*(np.asarray(a) + f / (FRAMES - 1) * (np.asarray(b) - np.asarray(a)))) for _, _, a, b in OBJECTS]
            for f in range(FRAMES)]


def paint_clean_frames() -> np.ndarray:
    """(FRAMES, H, W, 3) float frames before sensor noise."""
    ground = _ground_xy()
    frames = []
    for centres in _poses():
        shadowed = np.zeros(ground.shape[:2], dtype=bool)
        for (kind, _, _, _), centre in zip(OBJECTS, centres):
            shadowed |= _marched_shadow(kind, CUBE_YAW, ground - centre[:2], REACH)
        image = FLOOR_RGB * np.where(shadowed[..., None], SHADOW_RATIO, 1.0)
        paint_objects(image, [(kind, colour) for kind, colour, _, _ in OBJECTS], centres)
        frames.append(image)
    return np.stack(frames)


@pytest.fixture(scope="module")
def clean_frames() -> np.ndarray:
    return paint_clean_frames()  # the marching is the slow part: painted once for every noise draw


def _decoded(tmp_path_factory, clean: np.ndarray, seed: int) -> np.ndarray:
    """(FRAMES, H, W, 3) uint8: the clean frames with the sensor noise of ``seed``, h264-encoded and decoded."""
    rng = np.random.default_rng(seed)
    return as_decoded(tmp_path_factory, f"cast_shadows_{seed}", np.stack([grainy(image, rng) for image in clean]))


@pytest.fixture(scope="module")
def shadow_video(tmp_path_factory, clean_frames) -> np.ndarray:
    return _decoded(tmp_path_factory, clean_frames, NOISE_SEEDS[0])


def _azimuth_elevation(reach: np.ndarray) -> tuple[float, float]:
    """The light's azimuth and elevation (deg) of a reach (reach_of's inverse)."""
    return (math.degrees(math.atan2(-reach[1], -reach[0])) % 360.0, math.degrees(math.atan2(1.0, float(np.linalg.norm(reach)))))


def test_the_light_is_calibrated_from_the_coloured_objects_shadows(shadow_video):
    segments = ClassicalSegmenter().segment(shadow_video)
    poses = _poses()
    samples: list[ShadowSample] = []
    for frame in range(0, FRAMES, 8):
        for (kind, colour, _, _), centre in zip(OBJECTS, poses[frame]):
            if colour != "gray":
                window, sil = silhouette(CAMERA, kind, centre, SIZE, 0.0)
                samples.append(shadow_sample(CAMERA, segments[frame].labels, kind, centre, SIZE, 0.0, window, sil))
    reach = estimate_reach(samples)
    assert reach is not None
    azimuth, elevation = _azimuth_elevation(reach)
    assert abs((azimuth - 210.0 + 180.0) % 360.0 - 180.0) < 5.0 and abs(elevation - 40.0) < 4.0, (azimuth, elevation)
    # the same samples without their shadow-like pixels: no shadow to explain, no light
    bare = [ShadowSample(s.kind, s.size, s.yaw, s.offsets[~s.dark], s.dark[~s.dark]) for s in samples]
    assert estimate_reach(bare) is None


def test_a_grey_object_holding_its_deep_shadow_is_placed_by_its_body(tmp_path_factory, clean_frames):
    """Placed by its body, its shadow not an object (before perception.shadows: 7.4 cm off and a second grey track).

    Judged over six draws of sensor noise, not one: the grey body and its shadow are nearly as deep, and the outcome
    of one draw turns on a few pixels. On 18 draws (these 6 seeds x CRF 18 / 23 / 28) the cube's track was 0.5-1.3 cm
    off (median over its frames) on 10, 2.2-2.7 cm on 7 and 5 cm on one; a second grey track (its shadow, or a piece)
    came out on 3 (before colour evidence had to exceed compression's error: 8, 9, one 16 cm off, and 5). Its shape is
    not asserted: pooled over its tracklets cube and cylinder nearly tie."""
    truth = np.array([pose[2] for pose in _poses()])
    medians, extra_tracks = [], 0
    for seed in NOISE_SEEDS:
        observations, _ = perceive_frames(_decoded(tmp_path_factory, clean_frames, seed), CAMERA)
        grey = [o for o in observations.objects if o.color == "gray"]
        assert grey, f"noise seed {seed}: no grey track, {[(o.color, o.shape.kind) for o in observations.objects]}"
        # the cube's own track: the grey one nearest to it
        medians.append(min(float(np.median(np.linalg.norm(t.positions[:, :2] - truth[t.frames, :2], axis=1))) for t in grey))
        extra_tracks += len(grey) > 1
    assert sum(m < 0.03 for m in medians) >= 5, f"per noise draw, the cube's track median error (m): {np.round(medians, 3)}"
    assert extra_tracks <= 2, f"{extra_tracks} of {len(NOISE_SEEDS)} noise draws have a second grey track"
