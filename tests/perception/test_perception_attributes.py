"""Attribute probabilities (perception/attributes.py); the material model's own tests are in test_material_model.py."""

from __future__ import annotations

import numpy as np

from perception.attributes import color_probabilities, material_probabilities, shape_probabilities
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
