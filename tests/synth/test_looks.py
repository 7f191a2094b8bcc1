"""Appearance variation (synth/looks.py): every look parameter changes the render or
the camera, the default look still makes the fixtures, the tune/heldout split is disjoint."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

from physmind.cli import main
from synth.generate import scene_draws
from synth.looks import (
    CRF_RANGE,
    DEFAULT_CAMERA_RANGES,
    DEFAULT_LOOK,
    FloorLook,
    LOOK_FAMILIES,
    MATERIAL_RANGES,
    PALETTE_SHADE_JITTER,
    camera_bands,
    look_document,
    look_seed_sequence,
    sample_look,
)
from synth.render import read_mp4, render_scene, write_mp4
from synth.scene import CAMERA_TARGET, camera_geometry, inside_view, sample_scene
from world.camera import project_with_depth
from synth.simulate import simulate

DATA = Path(__file__).resolve().parents[2] / "tests" / "data" / "synth"


def _look(family: str, index: int):
    return sample_look(np.random.default_rng(look_seed_sequence(7, index, family)), family, CAMERA_TARGET)


def _looks(family: str, count: int = 300):
    return [_look(family, i) for i in range(count)]


def _first_frame(spec) -> np.ndarray:
    sim = simulate(spec, horizon_frames=1)
    rgb, _ = render_scene(spec, sim, frames=1)
    return rgb[0].astype(float)


def test_default_look_samples_the_fixture_scenes():
    """The default look draws exactly the synth-1 scenes of tests/data/synth (seed 12)
    and renders them as the fixture videos show them."""
    checked = 0
    for path in sorted((DATA / "ground_truth").glob("scene_*.json"))[:6]:
        gt = json.loads(path.read_text())
        if gt["generator"]["sampling_attempts"] != 1:
            continue  # accepted on a later draw; the first draw is not the fixture
        index = gt["scene_index"]
        spec = next(scene_draws(12, index)[2])
        assert spec.look == DEFAULT_LOOK
        assert np.allclose(spec.camera.position, gt["camera"]["position"], atol=1e-6)
        assert np.allclose(spec.camera.rotation, gt["camera"]["rotation"], atol=1e-7)
        for obj, truth in zip(sorted(spec.objects, key=lambda o: o.object_id), gt["objects"]):
            assert (obj.color, obj.material, obj.shape) == (truth["color"], truth["material"], truth["shape"])
            assert np.allclose(obj.position, truth["initial"]["position"], atol=1e-4)
        if checked == 0:
            # Same floor, lights and camera: frame 0 matches the fixture video up to h264 noise.
            video = read_mp4(DATA / "videos" / f"video_{index:05d}.mp4")[0].astype(float)
            assert np.abs(_first_frame(spec) - video).mean() < 2.0
        checked += 1
    assert checked >= 2


@pytest.fixture(scope="module")
def base_spec():
    look = _look("tune", 3)
    # A fixed base to vary: checker floor, hard shadows.
    floor = FloorLook(texture="checker", rgb=(0.6, 0.5, 0.4), rgb2=(0.45, 0.38, 0.3), tile=0.7, specular=0.1)
    look = dataclasses.replace(look, floor=floor, light=dataclasses.replace(look.light, shadows="hard"))
    return sample_scene(np.random.default_rng(5), 5, look)


@pytest.fixture(scope="module")
def base_frame(base_spec):
    return _first_frame(base_spec)


def _with(spec, **changes):
    look = spec.look
    for part, values in changes.items():
        look = dataclasses.replace(look, **{part: dataclasses.replace(getattr(look, part), **values)})
    return dataclasses.replace(spec, look=look)


@pytest.mark.parametrize(
    "part, values",
    [
        ("floor", {"texture": "flat"}),
        ("floor", {"texture": "clevrer"}),
        ("floor", {"texture": "speckle"}),
        ("floor", {"rgb": (0.3, 0.3, 0.3), "rgb2": (0.25, 0.25, 0.25)}),
        ("light", {"azimuth_deg": 20.0}),
        ("light", {"elevation_deg": 35.0}),
        ("light", {"intensity": 0.8}),
        ("light", {"tint": (0.7, 0.85, 1.0)}),
        ("light", {"ambient": 0.45}),
        ("light", {"shadows": "none"}),
        ("light", {"shadows": "soft"}),
    ],
)
def test_each_appearance_parameter_changes_the_render(base_spec, base_frame, part, values):
    changed = _with(base_spec, **{part: values})
    if changed.look == base_spec.look:
        pytest.fail(f"{part} {values}: the test's base look already has these values")
    difference = np.abs(_first_frame(changed) - base_frame)
    assert difference.mean() > 0.3 or (difference > 20).mean() > 0.002, (part, values, difference.mean())


@pytest.mark.parametrize("field, factor", [("distance", 1.25), ("tilt_deg", 0.8), ("fovy_deg", 1.25), ("yaw_deg", None)])
def test_each_camera_parameter_moves_the_camera(base_spec, field, factor):
    from synth.scene import look_camera

    camera_look = base_spec.look.camera
    value = getattr(camera_look, field)
    changed = dataclasses.replace(camera_look, **{field: value * factor if factor else value + 6.0})
    before, after = camera_geometry(look_camera(camera_look)), camera_geometry(look_camera(changed))
    if field == "distance":
        assert after["distance"] == pytest.approx(1.25 * before["distance"], rel=1e-6)
        assert after["object_pixels"] == pytest.approx(before["object_pixels"] / 1.25, rel=1e-6)  # objects smaller in pixels
        assert after["height"] == pytest.approx(1.25 * before["height"], rel=1e-6)
    elif field == "tilt_deg":
        assert after["tilt_deg"] == pytest.approx(0.8 * before["tilt_deg"], rel=1e-6)
        assert after["height"] < before["height"]
    elif field == "fovy_deg":
        assert after["fovy_deg"] == pytest.approx(1.25 * before["fovy_deg"], rel=1e-6)
        assert after["object_pixels"] < before["object_pixels"]
    else:
        target = np.array([camera_look.target])
        assert np.allclose(project_with_depth(look_camera(changed), target)[0], project_with_depth(look_camera(camera_look), target)[0], atol=1e-6)
        assert not np.allclose(look_camera(changed).position, look_camera(camera_look).position, atol=1e-3)
    # The scene sampler really uses the look's camera.
    spec = sample_scene(np.random.default_rng(5), 5, dataclasses.replace(base_spec.look, camera=changed))
    assert spec.camera == look_camera(changed)


def test_crf_changes_the_video(tmp_path, base_frame):
    frames = np.repeat(base_frame.astype(np.uint8)[None], 4, axis=0)
    errors, sizes = [], []
    for crf in CRF_RANGE:
        path = tmp_path / f"crf{crf}.mp4"
        write_mp4(path, frames, 25.0, crf)
        errors.append(np.abs(read_mp4(path).astype(float) - frames).mean())
        sizes.append(path.stat().st_size)
    assert sizes[1] < 0.8 * sizes[0] and errors[1] > errors[0]


def test_families_are_disjoint_in_floor_light_and_camera():
    tune, heldout = _looks("tune"), _looks("heldout")
    # Camera: every tune value lies outside heldout's bands and the default's range, and vice versa.
    for name in ("distance", "tilt_deg", "fovy_deg"):
        for family, looks, other in (("tune", tune, "heldout"), ("heldout", heldout, "tune")):
            values = np.array([getattr(look.camera, name) for look in looks])
            assert any(low <= v <= high for v in values for low, high in camera_bands(family, name))
            for low, high in camera_bands(other, name):
                assert not np.any((values >= low) & (values <= high)), (family, name)
            low, high = DEFAULT_CAMERA_RANGES[name]
            assert not np.any((values > low) & (values < high)) if high > low else not np.any(values == low)
        both = np.array([getattr(look.camera, name) for look in tune + heldout])
        centre = {"distance": 5.5, "tilt_deg": 45.0, "fovy_deg": 36.0}[name]
        assert both.min() <= 0.78 * centre and both.max() >= 1.22 * centre  # about +-25 % spanned
    # Floor: no heldout floor has a tune floor's texture and colour (colours at least 0.04 apart).
    tune_floors = [(f.floor.texture, np.array(f.floor.rgb)) for f in tune]
    for look in heldout:
        for texture, rgb in tune_floors:
            assert texture != look.floor.texture or np.abs(rgb - np.array(look.floor.rgb)).max() > 0.04
    assert {look.floor.texture for look in heldout} >= {"clevrer"}  # the real CLEVRER floor is held out
    # Lights: key-light azimuth, elevation and intensity ranges do not overlap.
    for field in ("azimuth_deg", "elevation_deg", "intensity"):
        a = [getattr(look.light, field) for look in tune]
        b = [getattr(look.light, field) for look in heldout]
        assert max(a) < min(b) or max(b) < min(a), field
    # Shared factors are drawn in both: every shadow style, crf 18..30.
    for looks in (tune, heldout):
        assert {look.light.shadows for look in looks} == {"hard", "soft", "none"}
        crfs = [look.crf for look in looks]
        assert min(crfs) == 18 and max(crfs) == 30


@pytest.mark.parametrize(
    "material, values",
    [
        ("metal", {"metal_specular": 0.0}),
        ("metal", {"metal_shininess": 0.0}),
        ("metal", {"metal_body": 1.0}),
        ("rubber", {"rubber_specular": 0.9}),
        ("rubber", {"rubber_shininess": 1.0, "rubber_specular": 0.5}),
        ("rubber", {"paint_shades": ((0.7, 0.7, 0.7),) * 8}),
    ],
)
def test_each_material_parameter_changes_the_render(base_spec, material, values):
    objects = tuple(dataclasses.replace(o, material=material) for o in base_spec.objects)
    spec = dataclasses.replace(base_spec, objects=objects)
    changed = _with(spec, materials=values)
    if changed.look == spec.look:
        pytest.fail(f"{values}: the test's base look already has these values")
    difference = np.abs(_first_frame(changed) - _first_frame(spec))
    assert (difference > 10).sum() > 30, (material, values, (difference > 10).sum())


def test_families_are_disjoint_in_how_materials_render():
    tune, heldout = _looks("tune"), _looks("heldout")
    for name in MATERIAL_RANGES["tune"]:
        a = [getattr(look.materials, name) for look in tune]
        b = [getattr(look.materials, name) for look in heldout]
        assert max(a) < min(b) or max(b) < min(a), name
    # The default look's metal (specular 1, shininess 0.7, body 0.62) is in neither tune's ranges ...
    assert not MATERIAL_RANGES["tune"]["metal_specular"][0] <= 1.0 <= MATERIAL_RANGES["tune"]["metal_specular"][1]
    assert not MATERIAL_RANGES["heldout"]["metal_body"][0] <= 0.62 <= MATERIAL_RANGES["heldout"]["metal_body"][1]
    # ... and metal is still the shinier material in every look.
    for look in tune + heldout:
        m = look.materials
        assert m.metal_specular > m.rubber_specular and m.metal_shininess > m.rubber_shininess
        shades = np.array(m.paint_shades)
        assert np.all(np.abs(shades - 1.0) <= PALETTE_SHADE_JITTER) and np.ptp(shades) > 0
    assert DEFAULT_LOOK.materials is None and "materials" not in look_document(DEFAULT_LOOK)


def test_object_count_and_partly_visible_objects():
    counts, edge_objects = set(), 0
    for i in range(40):
        spec = sample_scene(np.random.default_rng(i), i, _look("heldout", i))
        counts.add(len(spec.objects))
        for obj in spec.objects:
            if obj.role == "entering":
                continue
            pixel, _ = project_with_depth(spec.camera, np.array([obj.position]))
            assert inside_view(spec.camera, np.array([obj.position]))[0]  # its centre is in view ...
            radius = camera_geometry(spec.camera)["object_pixels"] / 2
            u, v = pixel[0]
            edge_objects += int(u < radius or u > spec.camera.width - radius or v > spec.camera.height - radius)  # ... part of it is not
    assert min(counts) == 3 and max(counts) == 8
    assert edge_objects >= 5


def test_look_document_round_trips_as_json():
    for family in LOOK_FAMILIES:
        document = json.loads(json.dumps(look_document(_look(family, 1))))
        assert document["family"] == family and CRF_RANGE[0] <= document["crf"] <= CRF_RANGE[1]
        if family != "default":
            assert set(document["camera"]) >= {"distance", "height", "tilt_deg", "fovy_deg"}
            assert document["light"]["shadows"] in ("hard", "soft", "none")
            assert 0.0 <= document["materials"]["metal_specular"] <= 1.0


def test_cli_rejects_an_unknown_look_family(capsys):
    assert main(["synth", "--out", "/tmp/never_written", "--scenes", "1", "--looks", "sunny"]) == 2
    err = capsys.readouterr().err
    assert "--looks" in err and "Traceback" not in err
