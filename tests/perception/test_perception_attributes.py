"""Attribute probabilities (perception/attributes.py); the material model's own tests are in test_material_model.py."""

from __future__ import annotations

import numpy as np

from perception.attributes import color_of, color_probabilities, color_votes, material_probabilities, shape_probabilities
from perception.types import NEUTRAL, Detection
from world.types import COLORS

def test_attribute_probabilities_are_distributions_that_follow_the_evidence():
    votes = np.zeros(len(COLORS) + 1)
    votes[1 + COLORS.index("red")], votes[1 + COLORS.index("purple")], votes[0] = 700, 250, 50
    colour = color_probabilities(votes)
    assert set(colour) == set(COLORS) and abs(sum(colour.values()) - 1) < 1e-9
    assert max(colour, key=colour.get) == "red" and colour["purple"] > colour["blue"]
    hueless = np.zeros(len(COLORS) + 1)
    hueless[0] = 900
    assert max(color_probabilities(hueless).items(), key=lambda kv: kv[1])[0] == "gray"
    shape = shape_probabilities({"sphere": 0.55, "cube": 0.8, "cylinder": 0.75})
    assert shape["cube"] > shape["cylinder"] > shape["sphere"] and abs(sum(shape.values()) - 1) < 1e-9
    # a colder temperature is more sure of the same evidence
    assert shape_probabilities({"sphere": 0.55, "cube": 0.8, "cylinder": 0.75}, temperature=0.01)["cube"] > shape["cube"]
    assert material_probabilities(0.5) == {"rubber": 0.5, "metal": 0.5}
    sure, unsure = material_probabilities(0.9, temperature=0.5), material_probabilities(0.9, temperature=2.0)
    assert sure["metal"] > 0.9 > unsure["metal"] > 0.5 and abs(sure["metal"] + sure["rubber"] - 1) < 1e-12


def _painted(pixels: list[tuple[tuple[int, int, int], int]]) -> tuple[list, np.ndarray]:
    """One detection over a frame painted with (rgb, pixel count) runs, 5 grey levels of noise."""
    rgb = np.concatenate([np.tile(np.asarray(colour, float), (count, 1)) for colour, count in pixels])
    rgb = np.clip(rgb + np.random.default_rng(0).normal(0.0, 5.0, rgb.shape), 0, 255).astype(np.uint8)
    frames = np.zeros((1, 1, len(rgb), 3), np.uint8)
    frames[0, 0] = rgb
    xs = np.arange(len(rgb), dtype=np.int32)
    return [Detection(0, np.zeros_like(xs), xs, NEUTRAL, False, 1)], frames


def test_a_red_metal_with_broad_highlights_is_red_and_a_brown_or_grey_object_keeps_its_colour():
    # fresh held-out set 63636: 7 of its 8 colour errors were red metal objects read brown (beliefs brown 0.43-0.61):
    # red mixed with 20-50 % white light labels brown pixel by pixel (the chromaticity moves towards grey, nearer brown's)
    red_metal = _painted([((173, 35, 35), 400), ((189, 78, 78), 300), ((205, 123, 123), 300)])  # paint, 80 % and 60 % paint
    assert color_of(*red_metal) == "red"  # main: brown
    assert max(color_probabilities(color_votes(*red_metal)).items(), key=lambda kv: kv[1])[0] == "red"
    brown = _painted([((173, 116, 37), 500), ((199, 161, 98), 300), ((128, 86, 28), 200)])  # paint, highlight, shade
    assert color_of(*brown) == "brown"
    grey = _painted([((120, 120, 122), 700), ((173, 35, 35), 100)])  # a grey body mirroring a red neighbour
    assert color_of(*grey) == "gray"
