"""An object with the floor's chroma keeps its place and shape when its top passes for floor (lift.fit_primitive's
free_top, attributes.shape_overlap's), and a warm-started fit does not keep a wrong pose (lift.fit_detection).

A top face gets the light the floor gets, so a grey top on a grey floor is labelled floor; counted against the
primitive, it slid the fit toward the camera onto the object's free shadow (11-31 cm on development scene 7373/17)
and decided cubes and cylinders to be spheres. Geometry first (the upward surface against an independent
ray-plane intersection), then synthetic label maps, then MuJoCo renders of grey objects on a floor of their own
paint (a seed no fixture and no tuning used)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from bench.bench_grey_floor import perceived_rows, table
from perception.background import AMBIGUOUS, FLOOR, OBJECT
from perception.geometry import ground_jacobian, silhouette, silhouette_and_top, window_rays
from perception.lift import Fit, fit_detection
from perception.segment import paint_like_floor
from perception.types import Detection
from synth.generate import scene_draws
from world.observations import DEFAULT_OBJECT_SIZE as SIZE

CAMERA_SEED = 902283  # a held-out look's camera, used by no fixture and no tuning
CENTRES = ([0.3, 0.5, SIZE], [-1.0, 1.2, SIZE], [1.2, -0.5, SIZE])


def _camera():
    return next(scene_draws(CAMERA_SEED, 0, "heldout")[2]).camera


def _full(camera, window, mask: np.ndarray) -> np.ndarray:
    out = np.zeros((camera.height, camera.width), dtype=bool)
    out[window.top:window.bottom, window.left:window.right] = mask
    return out


@pytest.mark.parametrize("kind", ["cube", "cylinder"])
def test_the_upward_surface_is_the_top_face(kind):
    """The pixels whose ray meets the plane z = 2 x size inside the footprint, first of the primitive's surfaces."""
    camera = _camera()
    yaw = 0.4
    for centre in CENTRES:
        window, sil, top = silhouette_and_top(camera, kind, np.asarray(centre), SIZE, yaw)
        rays = window_rays(camera, window)
        t = (2 * SIZE - camera.position[2]) / rays[..., 2]
        x = camera.position[0] + t * rays[..., 0] - centre[0]
        y = camera.position[1] + t * rays[..., 1] - centre[1]
        if kind == "cube":
            c, s = math.cos(yaw), math.sin(yaw)
            inside = (np.abs(c * x + s * y) <= SIZE) & (np.abs(-s * x + c * y) <= SIZE)
        else:
            inside = x * x + y * y <= SIZE * SIZE
        expected = inside & (t > 0)
        assert top.any() and (top & ~sil).sum() == 0
        assert (top != expected).sum() <= 0.02 * expected.sum(), (centre, int((top != expected).sum()), int(expected.sum()))


def _camouflaged(camera, kind: str, centre, yaw: float = 0.3):
    """Labels and detection of a primitive whose top is labelled floor (a grey top on a grey floor), its other
    faces object, and its shadow (the silhouette 0.15 m nearer the camera, outside the object) shadow-like."""
    centre = np.asarray(centre, float)
    window, sil, top = silhouette_and_top(camera, kind, centre, SIZE, yaw)
    body, lid = _full(camera, window, sil), _full(camera, window, top)
    toward = np.asarray(camera.position[:2], float) - centre[:2]
    near = centre.copy()
    near[:2] += 0.15 * toward / np.linalg.norm(toward)
    shadow_window, shadow = silhouette(camera, kind, near, SIZE, yaw)
    labels = np.full((camera.height, camera.width), FLOOR, dtype=np.uint8)
    labels[_full(camera, shadow_window, shadow) & ~body] = AMBIGUOUS
    labels[body & ~lid] = OBJECT
    ys, xs = np.nonzero(body & ~lid)
    return labels, Detection(0, ys.astype(np.int32), xs.astype(np.int32), 0, False, 0)


def _pixel_on_floor(camera, centre) -> float:
    """m: the side of one pixel on the plane of centres there."""
    return 1.0 / math.sqrt(abs(np.linalg.det(ground_jacobian(camera, np.asarray(centre, float)))))


@pytest.mark.parametrize("kind", ["cube", "cylinder"])
def test_a_top_labelled_floor_does_not_pull_the_fit(kind):
    """With the top free the fit is within a pixel (1.5-2 cm here); counted against, it slides onto the shadow
    (15-28 cm: the case it mends)."""
    camera = _camera()
    for centre in CENTRES:
        labels, detection = _camouflaged(camera, kind, centre)
        free = fit_detection(camera, kind, detection, labels, SIZE, free_top=True)
        counted = fit_detection(camera, kind, detection, labels, SIZE, free_top=False)
        pixel = _pixel_on_floor(camera, centre)
        assert np.linalg.norm(free.centre[:2] - centre[:2]) <= pixel, (centre, free.centre, pixel)
        assert np.linalg.norm(counted.centre[:2] - centre[:2]) > 3 * pixel, (centre, counted.centre, pixel)


def _patch(paint, floor, size: int = 60):
    """A frame of ``floor`` colour with a square of ``paint`` in the middle, labelled, and the square's detection."""
    frame = np.empty((size, size, 3), dtype=np.uint8)
    frame[:] = floor
    frame[20:40, 20:40] = paint
    labels = np.full((size, size), FLOOR, dtype=np.uint8)
    labels[20:40, 20:40] = OBJECT
    ys, xs = np.nonzero(labels == OBJECT)
    return frame, labels, Detection(0, ys.astype(np.int32), xs.astype(np.int32), 0, False, 0)


@pytest.mark.parametrize("paint, floor, expected", [
    ((60, 61, 64), (150, 152, 158), True),  # grey on a grey floor, darker
    ((200, 203, 210), (150, 152, 158), True),  # lit grey, brighter than the floor
    ((150, 30, 30), (150, 152, 158), False),  # red on grey
    ((90, 90, 90), (90, 110, 160), False),  # grey on a blue floor
])
def test_paint_like_floor_compares_chroma_not_brightness(paint, floor, expected):
    assert paint_like_floor(*_patch(paint, floor)) is expected


def test_a_warm_start_at_a_wrong_pose_is_not_kept():
    """A warm start 5 cm and 20 degrees off (a pose kept from frames the object entered by) scores about 0.8;
    main redid the search only when the score fell 0.12 below the previous frame's, and kept the yaw (34 degrees
    for 17; the position came right)."""
    camera = _camera()
    for centre in CENTRES:
        window, sil = silhouette(camera, "cube", np.asarray(centre), SIZE, 0.3)
        body = _full(camera, window, sil)
        labels = np.where(body, OBJECT, FLOOR).astype(np.uint8)
        ys, xs = np.nonzero(body)
        detection = Detection(0, ys.astype(np.int32), xs.astype(np.int32), 0, False, 0)
        wrong = np.asarray(centre, float) + [0.05, 0.0, 0.0]
        previous = Fit(wrong, 0.3 + math.radians(20), 0.8, int(body.sum()))
        fit = fit_detection(camera, "cube", detection, labels, SIZE, previous)
        yaw_error = abs((fit.yaw - 0.3 + math.pi / 4) % (math.pi / 2) - math.pi / 4)  # a cube repeats every 90 degrees
        assert np.linalg.norm(fit.centre[:2] - np.asarray(centre[:2])) <= 0.01, (centre, fit.centre)
        assert yaw_error <= math.radians(4), (centre, math.degrees(fit.yaw))


GREY_SEED = 902291  # scenes of the MuJoCo test below: used by no fixture, no tuning (seeds 613331 and 902283 were read)
GREY_SCENES = 8


@pytest.mark.slow
def test_grey_objects_on_a_floor_of_their_paint(tmp_path):
    """Every object grey, the floor flat and of the grey paint's own albedo (bench.bench_grey_floor): tops are
    floor-like by construction. At least half the followed objects within 3 cm (median over the track); main, on
    this seed: 14 of 40 (0.35), with 17 cubes and cylinders read as spheres (docs/benchmarks.md, twenty-first round)."""
    rows = [row for index in range(GREY_SCENES) for row in perceived_rows(GREY_SEED, index, tmp_path)]
    near = sum(error <= 0.03 for _, _, error in rows)
    assert len(rows) >= 30, f"only {len(rows)} objects followed"
    assert near >= 0.5 * len(rows), f"{near}/{len(rows)} within 3 cm\n" + table(rows)
