"""The vectorised perception kernels give what a plain per-pixel / per-shift reference gives.

Each kernel was rewritten for speed (issue 12, section 3) with the promise of unchanged results; these
tests hold that promise on small crafted inputs, so a later "optimisation" that changes a result fails.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage as ndi

from perception.background import (AMBIGUOUS, BRIGHT_OBJECT, CANDIDATE_DIFFERENCE, CHROMA_OBJECT, DARK_OBJECT, DEEP,
                                   FLOOR, FLOOR_RATIO, MIN_FLOOR_SAMPLES, NOISE_MULTIPLE, OBJECT, SHADOW_QUANTILE, Background,
                                   _floor_seen, classify_pixels, fit_floor, floor_range)
from perception.geometry import Box2D, ground_jacobian, window_rays
from perception.lift import shift_scores
from perception.segment import DARK_HUE_SPREAD, MIN_BRIGHTNESS, MIN_SATURATION, fill_holes, open_2x2, pixel_hue_labels
from perception.types import NEUTRAL, Detection
from world.camera import look_at_camera, pixel_rays, project
from world.types import CLEVR_PALETTE_RGB, COLORS


def _reference_labels(frame: np.ndarray, background: Background) -> np.ndarray:
    """classify_pixels pixel by pixel, straight from its definition (docs/perception.md, background.py)."""
    height, width = frame.shape[:2]
    image, noise = background.image.astype(np.float64), background.noise.astype(np.float64)
    labels = np.zeros((height, width), np.uint8)
    for y in range(height):
        for x in range(width):
            neighbours = image[max(y - 1, 0):y + 2, max(x - 1, 0):x + 2].reshape(-1, 3)
            tolerance = max(CANDIDATE_DIFFERENCE, NOISE_MULTIPLE * noise[y, x])
            low = np.floor(neighbours.min(axis=0) - tolerance)
            high = np.ceil(neighbours.max(axis=0) + tolerance)
            value = frame[y, x].astype(np.float64)
            if np.all((value >= low) & (value <= high)):
                continue  # inside the floor range: floor
            ratio = value / np.maximum(image[y, x], 1.0)
            mean = ratio.mean()
            chroma = np.abs(ratio - mean).max() / max(mean, 0.05)
            limit = CHROMA_OBJECT + NOISE_MULTIPLE * noise[y, x] / max(image[y, x].mean(), 1.0)
            levels = (np.abs(ratio - mean) * np.maximum(image[y, x], 1.0)).max()  # the chroma change in grey levels
            coloured = chroma >= limit and (levels >= CANDIDATE_DIFFERENCE or mean >= DARK_OBJECT)
            if coloured or mean > BRIGHT_OBJECT:
                labels[y, x] = OBJECT
            elif mean < DARK_OBJECT:
                labels[y, x] = DEEP
            elif mean >= FLOOR_RATIO:
                labels[y, x] = FLOOR
            else:
                labels[y, x] = AMBIGUOUS
    return labels


def _crafted_background(rng: np.random.Generator, height: int = 14, width: int = 17) -> Background:
    """A floor with a gradient and texture, saturated corners (0 and 255, where the uint8 range is clipped) and noise."""
    v, u = np.mgrid[0:height, 0:width]
    image = np.stack([110 + 3 * u, 130 + 2 * v, 150 - u], axis=-1).astype(np.float32) + rng.normal(0, 6, (height, width, 3)).astype(np.float32)
    image[:3, :3] = 2.0
    image[-3:, -3:] = 253.0
    image = np.clip(np.round(image), 0, 255).astype(np.float32)
    noise = rng.uniform(0, 6, (height, width)).astype(np.float32)
    return Background(image=image, floor_fit=image.copy(), static=np.zeros((height, width), bool), noise=noise)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_classify_pixels_matches_the_per_pixel_rule(seed):
    rng = np.random.default_rng(seed)
    background = _crafted_background(rng)
    base = background.image
    frame = base * rng.choice([1.0, 0.97, 0.8, 0.6, 0.4, 1.2], size=base.shape[:2])[..., None]  # floor, shadows, dark, bright
    frame = frame + rng.normal(0, 5, base.shape) + np.where(rng.random(base.shape[:2]) < 0.2, 1, 0)[..., None] * [60, -40, 0]
    frame = np.clip(np.round(frame), 0, 255).astype(np.uint8)
    frame[0, 0] = (0, 0, 0)
    frame[-1, -1] = (255, 255, 255)
    expected = _reference_labels(frame, background)
    assert len(np.unique(expected)) == 4  # the crafted frame exercises every label
    np.testing.assert_array_equal(classify_pixels(frame, background, floor_range(background)), expected)


def _reference_shift_scores(evidence: np.ndarray, mask: np.ndarray) -> np.ndarray:
    height, width = mask.shape
    out = np.zeros((evidence.shape[0] - height + 1, evidence.shape[1] - width + 1))
    for dy in range(out.shape[0]):
        for dx in range(out.shape[1]):
            out[dy, dx] = evidence[dy:dy + height, dx:dx + width][mask].sum()
    return out


@pytest.mark.parametrize("radius,height,width,fill", [(3, 12, 15, 0.5), (0, 4, 6, 0.7), (2, 1, 1, 1.0), (4, 9, 7, 0.0), (1, 10, 10, 0.95)])
def test_shift_scores_are_the_evidence_summed_under_each_shifted_silhouette(radius, height, width, fill):
    rng = np.random.default_rng(radius * 100 + height)
    evidence = rng.choice(np.array([-1.0, 0.0, 2.0], np.float32), size=(height + 2 * radius, width + 2 * radius))
    mask = rng.random((height, width)) < fill  # ragged rows: several runs per row, empty rows
    np.testing.assert_array_equal(shift_scores(evidence, mask), _reference_shift_scores(evidence, mask))


def test_shift_scores_of_a_disc_peak_where_the_disc_is():
    yy, xx = np.mgrid[0:21, 0:21]
    disc = (yy - 10) ** 2 + (xx - 10) ** 2 <= 64
    evidence = np.full((29, 29), -1.0, np.float32)
    evidence[7:7 + 21, 5:5 + 21][disc] = 2.0  # the object's pixels at shift (dy, dx) = (7, 5) of a 4 px search
    scores = shift_scores(evidence, disc)
    assert scores.shape == (9, 9)
    assert np.unravel_index(int(np.argmax(scores)), scores.shape) == (7, 5)
    assert scores.max() == 2.0 * disc.sum()


def _reference_open_2x2(mask: np.ndarray) -> np.ndarray:
    out = np.zeros_like(mask)
    for y in range(mask.shape[0] - 1):
        for x in range(mask.shape[1] - 1):
            if mask[y:y + 2, x:x + 2].all():
                out[y:y + 2, x:x + 2] = True
    return out


@pytest.mark.parametrize("seed", range(6))
def test_opening_and_hole_filling_match_the_definitions(seed):
    rng = np.random.default_rng(seed)
    mask = rng.random((int(rng.integers(1, 25)), int(rng.integers(1, 25)))) < rng.uniform(0.3, 0.95)
    np.testing.assert_array_equal(open_2x2(mask), _reference_open_2x2(mask))
    np.testing.assert_array_equal(open_2x2(mask), ndi.binary_opening(mask, structure=np.ones((2, 2), bool)))
    np.testing.assert_array_equal(fill_holes(mask), ndi.binary_fill_holes(mask))


def test_a_ring_is_filled_and_a_notched_ring_is_not():
    ring = np.zeros((9, 9), bool)
    ring[1:8, 1:8] = True
    ring[3:6, 3:6] = False
    assert fill_holes(ring)[4, 4]
    notched = ring.copy()
    notched[4, 1:3] = False  # the hole reaches the border through a 4-connected channel
    assert not fill_holes(notched)[4, 4]


def _reference_hues(rgb: np.ndarray, dark_hues: bool = False) -> np.ndarray:
    chromatic = [c for c in COLORS if c != "gray"]
    out = np.full(len(rgb), NEUTRAL)
    for k, pixel in enumerate(rgb.astype(np.float64)):
        high, low = pixel.max(), pixel.min()
        bright_enough = high >= MIN_BRIGHTNESS or (dark_hues and high - low >= DARK_HUE_SPREAD)
        if high - low >= MIN_SATURATION * max(high, 1.0) and bright_enough:
            chroma = pixel / max(pixel.sum(), 1.0)
            distances = [np.sum((chroma - np.asarray(CLEVR_PALETTE_RGB[c], float) / sum(CLEVR_PALETTE_RGB[c])) ** 2) for c in chromatic]
            out[k] = COLORS.index(chromatic[int(np.argmin(distances))])
    return out


def test_pixel_hues_are_the_nearest_palette_chromaticity():
    rng = np.random.default_rng(5)
    palette = np.array([CLEVR_PALETTE_RGB[c] for c in COLORS], float)
    rgb = np.clip(palette[rng.integers(0, len(palette), 400)] * rng.uniform(0.3, 1.3, (400, 1)) + rng.normal(0, 12, (400, 3)), 0, 255)
    rgb = np.concatenate([rgb.astype(np.uint8), [[0, 0, 0], [255, 255, 255], [20, 5, 5], [200, 150, 140]]]).astype(np.uint8)
    expected = _reference_hues(rgb)
    assert (expected == NEUTRAL).any() and len(set(expected.tolist())) >= 6
    np.testing.assert_array_equal(pixel_hue_labels(rgb), expected)
    dark = np.clip(palette[rng.integers(0, len(palette), 400)] * rng.uniform(0.02, 0.2, (400, 1)) + rng.normal(0, 3, (400, 3)), 0, 255)
    dark = dark.astype(np.uint8)
    expected_dark = _reference_hues(dark, dark_hues=True)
    assert (expected_dark != _reference_hues(dark)).any()  # the crafted dark pixels exercise the dark rule
    np.testing.assert_array_equal(pixel_hue_labels(dark, dark_hues=True), expected_dark)


def test_dark_paints_keep_their_hue_for_a_tracks_colour_and_dark_greys_have_none():
    """Each paint darkened to a brightest channel of 25 grey levels (Blender's dark metal bodies reach 23)."""
    chromatic = [c for c in COLORS if c != "gray"]
    paints = np.array([CLEVR_PALETTE_RGB[c] for c in chromatic], float)
    dark = np.round(paints * 25.0 / paints.max(axis=1, keepdims=True)).astype(np.uint8)
    assert (pixel_hue_labels(dark) == NEUTRAL).all()  # segmentation: below MIN_BRIGHTNESS, no hue
    assert [COLORS[k] for k in pixel_hue_labels(dark, dark_hues=True)] == chromatic
    dark_greys = np.array([[20, 16, 13], [25, 25, 27], [12, 9, 6]], np.uint8)
    assert (pixel_hue_labels(dark_greys, dark_hues=True) == NEUTRAL).all()
    # a track's colour is voted with the dark rule: a dark brown body is brown, not grey
    from perception.attributes import color_of
    frames = np.zeros((1, 12, 12, 3), np.uint8)
    frames[0, 2:10, 2:10] = dark[chromatic.index("brown")]
    ys, xs = np.nonzero(frames[0].any(axis=-1))
    assert color_of([Detection(0, ys.astype(np.int32), xs.astype(np.int32), NEUTRAL, False, 1)], frames) == "brown"


def _reference_fit_floor(median: np.ndarray, iterations: int = 4) -> np.ndarray:
    """The robust quadratic fit evaluated over the whole image at every iteration (the form before the speed-up)."""
    height, width, _ = median.shape
    v, u = np.mgrid[0:height, 0:width].astype(np.float64)
    u, v = u / width - 0.5, v / height - 0.5
    design = np.stack([np.ones_like(u), u, v, u * u, u * v, v * v], axis=-1).reshape(-1, 6)
    values = median.reshape(-1, 3).astype(np.float64)
    keep = np.ones(len(values), bool)
    sample = np.zeros(len(values), bool)
    sample[::max(1, len(values) // 20000)] = True
    for _ in range(iterations):
        coefficients, *_ = np.linalg.lstsq(design[keep & sample], values[keep & sample], rcond=None)
        fit = design @ coefficients
        residual = np.abs(values - fit).max(axis=1)
        keep = residual < 3.0 * max(1.4826 * float(np.median(residual[keep & sample])), 1.0)
    return fit.reshape(height, width, 3).astype(np.float32)


def test_floor_fit_is_the_full_image_iteration():
    rng = np.random.default_rng(3)
    v, u = np.mgrid[0:200, 0:260].astype(np.float32)
    median = np.stack([100 + 0.1 * u, 120 + 0.05 * v + 0.0002 * u * v, 140 - 0.08 * u], axis=-1) + rng.normal(0, 2, (200, 260, 3))
    median[50:90, 60:110] = 30.0  # a resting dark object: an outlier region
    np.testing.assert_allclose(fit_floor(median.astype(np.float32)), _reference_fit_floor(median.astype(np.float32)), rtol=0, atol=1e-3)


def test_window_rays_are_the_pixel_rays_of_that_camera():
    first = look_at_camera(eye=(3.0, -4.0, 3.5), target=(0.0, 0.0, 0.0), width=48, height=32, vertical_fov_deg=50.0)
    second = look_at_camera(eye=(-2.0, 3.0, 5.0), target=(0.5, 0.0, 0.0), width=48, height=32, vertical_fov_deg=40.0)
    for camera in (first, second, first):  # the per-camera grid must not leak between cameras
        window = Box2D(5, 17, 9, 30)
        v, u = np.mgrid[5:17, 9:30].astype(float)
        np.testing.assert_array_equal(window_rays(camera, window), pixel_rays(camera, u, v))


def test_ground_jacobian_is_the_per_axis_finite_difference():
    camera = look_at_camera(eye=(3.0, -4.0, 3.5), target=(0.0, 0.0, 0.0), width=480, height=320, vertical_fov_deg=50.0)
    point = np.array([0.4, -0.3, 0.2])
    columns = []
    for axis in range(2):
        moved = point.copy()
        moved[axis] += 1e-3
        columns.append((project(camera, moved) - project(camera, point)) / 1e-3)
    np.testing.assert_allclose(ground_jacobian(camera, point), np.stack(columns, axis=1), rtol=1e-9, atol=1e-9)


@pytest.mark.parametrize("seed", [0, 1])
def test_floor_seen_at_resting_places_is_the_bright_state_of_the_floor_like_samples(seed):
    """background._floor_seen, pixel by pixel from its definition: at a static pixel, the SHADOW_QUANTILE
    percentile of the samples within the threshold of the model, with its chroma and closer to it than to
    the median, when at least MIN_FLOOR_SAMPLES are; else the model."""
    rng = np.random.default_rng(seed)
    count, height, width, threshold = 25, 12, 14, 20.0
    model = np.full((height, width, 3), 150.0, np.float32) + rng.normal(0, 3, (height, width, 3)).astype(np.float32)
    floor = np.clip(model + rng.normal(0, 8, (height, width, 3)), 0, 255)
    resting = rng.uniform(0, 255, (height, width, 3))  # a resting object's colour
    covered = rng.uniform(size=(count, height, width)) < rng.uniform(0.3, 1.0, (1, height, width))
    sampled = np.where(covered[..., None], resting, floor) + rng.normal(0, 2, (count, height, width, 3))
    sampled = np.clip(sampled, 0, 255).astype(np.uint8)
    median = np.median(sampled.astype(np.float32), axis=0)
    static = rng.uniform(size=(height, width)) < 0.7
    seen = _floor_seen(sampled, static, median, model, threshold)
    for y in range(height):
        for x in range(width):
            if not static[y, x]:
                assert np.array_equal(seen[y, x], model[y, x])
                continue
            values = sampled[:, y, x].astype(np.float64)
            ratio = values / np.maximum(model[y, x].astype(np.float64), 1.0)
            mean = ratio.mean(axis=1)
            from_model = np.abs(values - model[y, x]).max(axis=1)
            like = ((from_model <= threshold) & (from_model < np.abs(values - median[y, x]).max(axis=1))
                    & (np.abs(ratio - mean[:, None]).max(axis=1) < CHROMA_OBJECT * mean))
            expected = np.percentile(values[like], SHADOW_QUANTILE, axis=0) if like.sum() >= MIN_FLOOR_SAMPLES else model[y, x]
            np.testing.assert_allclose(seen[y, x], expected, rtol=0, atol=1e-3)
