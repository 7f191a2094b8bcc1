"""The material model (perception/material_model.py): metal and rubber told apart under a look it was never
trained on, calibrated probabilities, features that follow the floor's illumination, and a training
script that learns from examples."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from bench.train_attributes import fit, log_odds
from perception.attributes import material_probabilities
from perception.material_model import (TRACK_FEATURES, AppearanceWindow, appearance_window, appearance_windows, metal_probability,
                                       track_features)
from perception.pipeline import perceive_frames
from synth.generate import scene_draws
from synth.render import render_scene
from synth.scene import OBJECT_HALF_SIZE
from synth.simulate import simulate
from world.camera import backproject_to_height, project
from world.types import CLEVR_PALETTE_RGB, SHAPE_KINDS

SEED = 913271  # used by no fixture, no benchmark and no training set
FRAMES = 40
PAIRS = (("blue", "cylinder"), ("yellow", "cube"), ("red", "sphere"))  # each colour/shape once metal, once rubber


@pytest.fixture(scope="module")
def pair_scene():
    """Six objects sliding slowly under a held-out look (synth.looks "heldout", never in the training sets):
    per PAIRS entry a metal and a rubber object of the same colour and shape. -> (specs, lifted tracks, camera)."""
    _, _, draws = scene_draws(SEED, 0, "heldout")
    spec = next(draws)
    camera = spec.camera
    template = spec.objects[0]
    spots = [(u, v) for v in (0.35, 0.72) for u in (0.22, 0.5, 0.78)]
    objects = []
    for k, (u, v) in enumerate(spots):
        color, shape = PAIRS[k % 3]
        centre = backproject_to_height(camera, np.array([[u * camera.width, v * camera.height]]), OBJECT_HALF_SIZE)[0]
        objects.append(replace(template, object_id=k, color=color, shape=shape, material="metal" if k < 3 else "rubber",
                               position=tuple(centre), velocity=(0.25, 0.0, 0.0), yaw=0.3, role="moving", launch_frame=0))
    spec = replace(spec, objects=tuple(objects))
    rgb, _ = render_scene(spec, simulate(spec, horizon_frames=FRAMES), frames=FRAMES)
    _, inter = perceive_frames(rgb, camera, fps=spec.fps)
    return spec, inter, camera, rgb


def _track_of(obj, lifted, camera):
    """The lifted track whose first position projects nearest the object's start (within 30 px)."""
    start = project(camera, np.asarray(obj.position)[None])[0]
    best = min(lifted, key=lambda t: np.linalg.norm(project(camera, t.positions[:1])[0] - start))
    assert np.linalg.norm(project(camera, best.positions[:1])[0] - start) < 30, f"object {obj.object_id} not found"
    return best


def _pair_probabilities(pair_scene) -> list[tuple[str, float, float]]:
    """Per PAIRS entry: (colour shape, P(metal) of the metal object's track, P(metal) of the rubber one's)."""
    spec, inter, camera, _ = pair_scene
    return [(f"{metal.color} {metal.shape}", _track_of(metal, inter["lifted"], camera).attributes.metal_probability,
             _track_of(rubber, inter["lifted"], camera).attributes.metal_probability)
            for metal, rubber in zip(spec.objects[:3], spec.objects[3:])]


@pytest.mark.slow
def test_metal_reads_more_metal_than_rubber_of_the_same_colour_and_shape_under_an_unseen_look(pair_scene):
    pairs = _pair_probabilities(pair_scene)
    assert all(p_metal > p_rubber for _, p_metal, p_rubber in pairs), pairs


@pytest.mark.slow
@pytest.mark.xfail(strict=True, reason="known gap (docs/benchmarks.md 'Material across renderers'): under this held-out "
                   "look the blue metal cylinder reads rubber (P(metal) 0.25, its rubber twin 0.05); strict, so a fix shows")
def test_metal_and_rubber_of_the_same_colour_and_shape_decided_right_under_an_unseen_look(pair_scene):
    pairs = _pair_probabilities(pair_scene)
    assert all(p_metal > 0.5 > p_rubber for _, p_metal, p_rubber in pairs), pairs


def _disc(color: str, body: float, highlight: float, light: float = 1.0, floor: float = 150.0, size=(120, 160)) -> AppearanceWindow:
    """Window of a shaded disc of ``color`` paint x ``body`` with a white highlight of ``highlight`` grey
    levels, on a floor of brightness ``floor``, everything lit by ``light``."""
    from perception.background import FLOOR, OBJECT
    from perception.types import Detection

    yy, xx = np.mgrid[: size[0], : size[1]]
    disc = np.hypot(yy - 60, xx - 80) <= 22
    frame = np.full((*size, 3), floor, dtype=np.float32)
    shading = 0.55 + 0.45 * np.clip(1.0 - (yy - 38) / 55.0, 0.0, 1.0)
    frame[disc] = body * np.asarray(CLEVR_PALETTE_RGB[color], np.float32) * shading[disc, None]
    frame[disc & (np.hypot(yy - 52, xx - 72) <= 7)] += highlight
    frame = np.clip(frame * light, 0, 255).astype(np.uint8)
    ys, xs = np.nonzero(disc)
    detection = Detection(frame=0, ys=ys.astype(np.int32), xs=xs.astype(np.int32), hue_label=0, touches_border=False, component=1)
    return appearance_window(detection, frame, np.where(disc, OBJECT, FLOOR).astype(np.uint8))


@pytest.mark.parametrize("light", [0.55, 1.3])
def test_features_follow_the_floor_illumination_not_absolute_brightness(light):
    """Dimming or brightening the whole scene (floor and object alike) leaves the features where they were."""
    for body, highlight in ((1.0, 0.0), (0.7, 90.0)):
        reference = track_features([_disc("green", body, highlight)], "green")
        scaled = track_features([_disc("green", body, highlight, light=light)], "green")
        # without a highlight the peak sits at its floor of 1 grey level, which does not scale
        compared = [k for k, name in enumerate(TRACK_FEATURES) if highlight or name != "peak"]
        assert scaled[compared] == pytest.approx(reference[compared], abs=0.06), dict(zip(TRACK_FEATURES, np.round(scaled - reference, 3)))


def test_no_floor_around_the_object_gives_an_even_probability():
    window = _disc("red", 1.0, 0.0)
    no_floor = replace(window, ring=np.zeros_like(window.ring))
    assert track_features([no_floor], "red") is None
    assert metal_probability([no_floor], "red", "cube") == 0.5


def _windows_of(obj, inter, rgb, camera) -> list[AppearanceWindow]:
    """Appearance windows of the tracklet whose first detection lies nearest the object's start."""
    start = project(camera, np.asarray(obj.position)[None])[0]
    track = min(inter["tracks"], key=lambda t: np.linalg.norm(t.detections[min(t.detections)].centroid - start))
    return appearance_windows([track.detections[f] for f in sorted(track.detections)], rgb, inter["segments"])


@pytest.mark.slow
def test_conflicting_frames_give_an_unsure_probability_that_sums_to_one(pair_scene):
    """A track whose frames are alternately a metal object's and a rubber one's (same colour and shape) is
    ambiguous: its probabilities sum to 1 and neither material gets more than 0.9."""
    spec, inter, camera, rgb = pair_scene
    metal, rubber = spec.objects[0], spec.objects[3]
    metal_windows, rubber_windows = _windows_of(metal, inter, rgb, camera), _windows_of(rubber, inter, rgb, camera)
    mixed = [w for pair in zip(metal_windows[::2], rubber_windows[::2]) for w in pair]
    assert metal_probability(metal_windows, metal.color, metal.shape) > metal_probability(rubber_windows, rubber.color, rubber.shape)
    probabilities = material_probabilities(metal_probability(mixed, metal.color, metal.shape))
    assert sum(probabilities.values()) == pytest.approx(1.0)
    assert max(probabilities.values()) <= 0.9, probabilities


@pytest.mark.parametrize("kind", ["trees", "logistic"])
def test_a_small_training_run_learns_metal_from_rubber(kind):
    """bench.train_attributes.fit (each model kind) on synthetic shiny and matte discs under random light, floor and paint
    tells held-out discs apart far above chance."""
    rng = np.random.default_rng(5)
    colors = [c for c in CLEVR_PALETTE_RGB if c != "gray"]

    def sample(n):
        x, y = [], []
        for _ in range(n):
            metal = bool(rng.integers(2))
            color = colors[int(rng.integers(len(colors)))]
            body = rng.uniform(0.5, 0.75) if metal else rng.uniform(0.8, 1.1)
            highlight = rng.uniform(60, 160) if metal else rng.uniform(0, 25)
            window = _disc(color, body, highlight, light=rng.uniform(0.6, 1.3), floor=rng.uniform(100, 200))
            x.append(track_features([window], color))
            y.append(float(metal))
        return np.asarray(x), np.asarray(y)

    x, y = sample(60)
    shapes = np.tile(np.eye(len(SHAPE_KINDS))[0], (len(y), 1))
    model = fit(x, shapes, y, kind=kind)
    x_test, y_test = sample(40)
    z = log_odds(model, x_test, np.tile(np.eye(len(SHAPE_KINDS))[0], (len(y_test), 1)))
    assert np.mean((z > 0) == (y_test > 0.5)) >= 0.9


def test_exported_boosted_trees_give_scikit_learns_log_odds_and_survive_json():
    """The shipped model kind: HistGradientBoostingClassifier's trees, exported for numpy-only inference,
    give its decision_function on unseen inputs (missing values too), before and after a JSON round trip."""
    from sklearn.ensemble import HistGradientBoostingClassifier

    from bench.train_attributes import exported_trees
    from perception.material_model import TreeEnsemble

    rng = np.random.default_rng(11)
    x = rng.normal(size=(500, 5))
    x[rng.random(x.shape) < 0.05] = np.nan
    y = (np.nan_to_num(x[:, 0]) * np.nan_to_num(x[:, 1]) + np.nan_to_num(x[:, 2]) > 0.2).astype(int)
    boosted = HistGradientBoostingClassifier(max_depth=3, max_iter=40, random_state=0).fit(x, y)
    trees = exported_trees(boosted)
    unseen = rng.normal(size=(300, 5))
    unseen[rng.random(unseen.shape) < 0.1] = np.nan
    expected = boosted.decision_function(unseen)
    for model in (trees, TreeEnsemble.from_json(trees.to_json())):
        assert np.allclose([model.raw(row) for row in unseen], expected, rtol=0, atol=1e-12)


def test_a_material_model_with_broken_trees_is_refused():
    """A shipped model whose node arrays disagree in length is a clear error at load, not a wrong P(metal)."""
    from perception.material_model import MaterialModel, shipped_model

    document = shipped_model().to_json()
    if "trees" not in document:
        pytest.fail("the shipped material model is expected to be boosted trees")
    document["trees"]["left"] = document["trees"]["left"][:-1]
    with pytest.raises(ValueError, match="trees"):
        MaterialModel.from_json(document)


def test_each_renderer_weighs_the_same_in_training():
    """renderer_weights: a renderer with 8 samples and one with 2 (set names 'renderer-look') get equal totals, mean 1."""
    from bench.train_attributes import renderer_weights

    sets = ["mujoco-a"] * 5 + ["mujoco-b"] * 3 + ["blender-c"] * 2
    weights = renderer_weights(sets)
    assert weights.mean() == pytest.approx(1.0)
    assert weights[:8].sum() == pytest.approx(weights[8:].sum())
    assert weights[0] == pytest.approx(weights[7])
