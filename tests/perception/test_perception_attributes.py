"""Material cues (perception/attributes.py) on synthetic frames: a matte and a shiny object are told
apart, and the cues calibrate themselves to the floor's observed illumination."""

from __future__ import annotations

import numpy as np
import pytest

from perception.attributes import color_probabilities, material_cues, material_of, material_probabilities, shape_probabilities
from perception.background import FLOOR, OBJECT
from perception.types import Detection, FrameSegments
from world.types import CLEVR_PALETTE_RGB, COLORS

SIZE = (120, 160)
CENTRE, RADIUS = (60, 80), 22


def _frame(color: str, body: float, highlight: float, light: float = 1.0, floor: float = 150.0):
    """(frame, segments, detection): a shaded disc of ``color`` paint x ``body`` with a white highlight of
    ``highlight`` grey levels on its upper left, on a floor of brightness ``floor``, all lit by ``light``."""
    yy, xx = np.mgrid[: SIZE[0], : SIZE[1]]
    distance = np.hypot(yy - CENTRE[0], xx - CENTRE[1])
    disc = distance <= RADIUS
    frame = np.full((*SIZE, 3), floor, dtype=np.float32)
    shading = 0.55 + 0.45 * np.clip(1.0 - (yy - CENTRE[0] + RADIUS) / (2.5 * RADIUS), 0.0, 1.0)  # lit from above
    paint = np.asarray(CLEVR_PALETTE_RGB[color], dtype=np.float32)
    frame[disc] = body * paint * shading[disc, None]
    spot = np.hypot(yy - CENTRE[0] + 8, xx - CENTRE[1] + 8) <= 7
    frame[spot & disc] += highlight
    frame = np.clip(frame * light, 0, 255).astype(np.uint8)
    labels = np.where(disc, OBJECT, FLOOR).astype(np.uint8)
    ys, xs = np.nonzero(disc)
    detection = Detection(frame=0, ys=ys.astype(np.int32), xs=xs.astype(np.int32), hue_label=0, touches_border=False, component=1)
    return frame[None], [FrameSegments(frame=0, labels=labels, detections=(detection,))], detection


@pytest.mark.parametrize("shape", ["sphere", "cube", "cylinder"])
@pytest.mark.parametrize("color", ["red", "blue", "yellow", "gray", "cyan"])
def test_matte_and_shiny_objects_are_told_apart(color, shape):
    frames, segments, det = _frame(color, body=1.0, highlight=0.0)
    assert material_of([det], frames, segments, color, shape)[0] == "rubber"
    frames, segments, det = _frame(color, body=0.7, highlight=150.0)
    assert material_of([det], frames, segments, color, shape)[0] == "metal"


def test_highlight_peak_needs_no_floor():
    """The peak is measured against the object's own lit level: a brighter floor leaves it unchanged,
    a stronger highlight raises it."""
    frames, segments, det = _frame("blue", 0.9, 100.0, floor=110.0)
    reference = material_cues([det], frames, segments, "blue")
    frames, segments, det = _frame("blue", 0.9, 100.0, floor=220.0)
    brighter_floor = material_cues([det], frames, segments, "blue")
    frames, segments, det = _frame("blue", 0.9, 40.0, floor=110.0)
    weaker_highlight = material_cues([det], frames, segments, "blue")
    assert brighter_floor.peak == pytest.approx(reference.peak, abs=0.02)
    assert brighter_floor.log_body < reference.log_body - 0.5  # the floor-relative cue does move
    assert weaker_highlight.peak < reference.peak - 0.5


@pytest.mark.parametrize("light", [0.55, 1.3])
def test_cues_follow_the_floor_illumination_not_absolute_brightness(light):
    """Dimming or brightening the whole scene (floor and object alike) leaves the cues where they were."""
    for body, highlight in ((1.0, 0.0), (0.7, 120.0)):
        frames, segments, det = _frame("green", body, highlight)
        reference = material_cues([det], frames, segments, "green")
        frames, segments, det = _frame("green", body, highlight, light=light)
        scaled = material_cues([det], frames, segments, "green")
        assert scaled.frames == reference.frames == 1
        assert scaled.specular == pytest.approx(reference.specular, abs=0.03)
        assert scaled.log_body == pytest.approx(reference.log_body, abs=0.03)
        assert scaled.desaturation == pytest.approx(reference.desaturation, abs=0.03)
        if highlight:  # without a highlight the peak is at its floor of 1 grey level
            assert scaled.peak == pytest.approx(reference.peak, abs=0.05)


def test_no_floor_around_the_object_gives_no_cue():
    frames, segments, det = _frame("red", 1.0, 0.0)
    segments = [FrameSegments(frame=0, labels=np.full(SIZE, OBJECT, dtype=np.uint8), detections=segments[0].detections)]
    cues = material_cues([det], frames, segments, "red")
    assert cues.frames == 0
    assert material_of([det], frames, segments, "red", "sphere")[1] == 0.5


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
