"""The POV-Ray renderer (synth/povray.py): same camera and geometry as MuJoCo's render,
the same dataset layout, its own look family, and a one-line error without povray.

These tests need the Debian package povray (`make install` installs it as root); without
it they fail with the install hint, they do not skip.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

import synth.generate
from physmind.cli import main
from synth.povray import floor_point_in_view, render_scene_povray, scene_povray_look
from synth.povray_look import (
    METAL_RANGES,
    POVRAY_FLOORS,
    PovFinish,
    PovFloor,
    PovLight,
    PovLook,
    povray_look_seed_sequence,
    sample_povray_look,
)
from synth.render import read_mp4, render_scene
from synth.scene import OBJECT_HALF_SIZE, ObjectSpec, SceneSpec, camera_from_pose
from synth.simulate import simulate
from world.camera import backproject_to_height
from world.types import COLORS

# Vivid, well separated paints (sRGB) so each object is found by its colour alone.
TEST_PAINTS = {"red": (0.85, 0.1, 0.1), "blue": (0.1, 0.2, 0.9), "green": (0.1, 0.75, 0.1), "yellow": (0.9, 0.85, 0.1)}


def _object(object_id: int, color: str, shape: str, position, yaw: float, velocity=(0.0, 0.0, 0.0)) -> ObjectSpec:
    return ObjectSpec(object_id=object_id, color=color, material="rubber", shape=shape,
                      position=(float(position[0]), float(position[1]), OBJECT_HALF_SIZE), velocity=velocity, yaw=yaw,
                      mass=0.5, friction=0.08, rolling_friction=0.015 if shape == "sphere" else 0.0,
                      torsional_friction=0.01 if shape == "sphere" else 0.0, restitution=0.7,
                      role="moving" if any(velocity) else "rest")


def _test_scene() -> SceneSpec:
    """Four objects spread over an off-axis view (camera turned 12 degrees, so a mirrored
    render would put them elsewhere); a yawed cube slides so frame 3 has a moved pose."""
    camera = camera_from_pose(5.0, 40.0, 12.0, 40.0, np.array([0.3, 0.2, 0.0]))
    pixels = np.array([[110.0, 210.0], [330.0, 110.0], [250.0, 250.0], [395.0, 235.0]])
    floor = backproject_to_height(camera, pixels, OBJECT_HALF_SIZE)
    objects = (
        _object(0, "red", "cube", floor[0], 0.5, velocity=(0.8, 0.3, 0.0)),
        _object(1, "blue", "cylinder", floor[1], 0.0),
        _object(2, "green", "sphere", floor[2], 0.0),
        _object(3, "yellow", "cube", floor[3], -0.3),
    )
    return SceneSpec(scene_index=0, camera=camera, objects=objects)


def _test_look(camera) -> PovLook:
    """Plain grey floor, one point light at the camera (each shadow hides behind its object), matte objects."""
    paints = tuple(TEST_PAINTS.get(c, (0.5, 0.5, 0.5)) for c in COLORS)
    return PovLook(
        floor=PovFloor("plain", (0.5, 0.5, 0.5), (0.5, 0.5, 0.5), 1.0, (0.0, 0.0), 0.0, 0.0),
        lights=(PovLight(tuple(camera.position), (1.0, 1.0, 1.0), 0.0),),
        sky_horizon=(0.8, 0.8, 0.8), sky_zenith=(0.6, 0.6, 0.7), ambient=0.3,
        metal=PovFinish(diffuse=0.4, specular=0.7, roughness=0.02, reflection=0.5, body=0.7),
        rubber=PovFinish(diffuse=0.9, specular=0.05, roughness=0.1, reflection=0.0, body=1.0),
        paints=paints,
    )


def _hue_deg(rgb: np.ndarray) -> np.ndarray:
    """(...,) HSV hue in degrees of (..., 3) RGB values."""
    r, g, b = np.moveaxis(rgb.astype(float), -1, 0)
    top, span = rgb.max(axis=-1).astype(float), np.maximum(np.ptp(rgb, axis=-1).astype(float), 1e-9)
    hue = np.where(top == r, (g - b) / span % 6, np.where(top == g, (b - r) / span + 2, (r - g) / span + 4))
    return 60.0 * hue


def _colour_labels(image: np.ndarray, spec: SceneSpec) -> np.ndarray:
    """(H, W) object id per pixel of a POV-Ray render: saturated pixels (the grey floor
    and sky are not) labelled by the nearest paint hue (within 25 deg); -1 elsewhere."""
    rgb = image.astype(float)
    saturation = np.ptp(rgb, axis=-1) / np.maximum(rgb.max(axis=-1), 1.0)
    ids = np.array([o.object_id for o in spec.objects])
    paint_hues = _hue_deg(np.array([TEST_PAINTS[o.color] for o in spec.objects]))
    gap = np.abs(_hue_deg(rgb)[..., None] - paint_hues)
    gap = np.minimum(gap, 360.0 - gap)
    return np.where((saturation > 0.3) & (gap.min(axis=-1) < 25.0), ids[gap.argmin(axis=-1)], -1)


def test_povray_render_matches_mujoco_camera_and_silhouettes():
    spec = _test_scene()
    sim = simulate(spec, horizon_frames=4)
    look = _test_look(spec.camera)
    _, instance = render_scene(spec, sim, frames=4)
    rgb = render_scene_povray(spec, sim, look, frames=4, processes=2)
    assert rgb.shape == (4, spec.camera.height, spec.camera.width, 3) and rgb.dtype == np.uint8
    moved = np.linalg.norm(sim.positions[3, 0] - sim.positions[0, 0])
    assert moved > 0.05  # frame 3 shows the sliding cube elsewhere: per-frame poses are used
    for frame in (0, 3):
        labels = _colour_labels(rgb[frame], spec)
        for obj in spec.objects:
            truth, found = instance[frame] == obj.object_id, labels == obj.object_id
            assert truth.sum() > 300, "the test scene must show every object"
            truth_centre = np.argwhere(truth).mean(axis=0)
            found_centre = np.argwhere(found).mean(axis=0)
            offset = float(np.linalg.norm(truth_centre - found_centre))
            iou = (truth & found).sum() / (truth | found).sum()
            assert offset <= 2.0, f"frame {frame} object {obj.object_id}: centroid {offset:.2f} px from MuJoCo's"
            assert iou > 0.9, f"frame {frame} object {obj.object_id}: silhouette IoU {iou:.3f}"


def test_povray_look_family_is_seeded_varied_and_reflective():
    looks = [scene_povray_look(_test_scene(), 11, index) for index in range(60)]
    again = scene_povray_look(_test_scene(), 11, 5)
    assert again == looks[5]
    assert {look.floor.kind for look in looks} == set(POVRAY_FLOORS)  # the CLEVRER image among them
    assert {len(look.lights) for look in looks} == {1, 2, 3}
    assert any(light.area_size > 0 for look in looks for light in look.lights)
    assert any(light.area_size == 0 for look in looks for light in look.lights)
    for look in looks:
        assert METAL_RANGES["reflection"][0] <= look.metal.reflection <= METAL_RANGES["reflection"][1]
        assert look.metal.body < 1.0 and look.rubber.reflection == 0.0
    # Lights aim around the point the camera looks at.
    target = np.array(floor_point_in_view(_test_scene().camera))
    key = np.array(looks[0].lights[0].position)
    assert math.dist(key[:2], target[:2]) < 14.0 and key[2] > 0
    other = sample_povray_look(np.random.default_rng(povray_look_seed_sequence(12, 5)), tuple(target))
    assert other != looks[5]


def _cheap_look(spec: SceneSpec, seed: int, index: int) -> PovLook:
    return _test_look(spec.camera)


@pytest.mark.slow
def test_povray_dataset_has_the_mujoco_layout(tmp_path, monkeypatch):
    mujoco_out, povray_out = tmp_path / "mujoco", tmp_path / "povray"
    assert main(["synth", "--out", str(mujoco_out), "--scenes", "1", "--seed", "5", "--start-index", "2"]) == 0
    # A cheap look (one point light, plain floor): the layout, not the look, is under test here.
    monkeypatch.setattr(synth.generate, "scene_povray_look", _cheap_look)
    assert main(["synth", "--out", str(povray_out), "--scenes", "1", "--seed", "5", "--start-index", "2",
                 "--renderer", "povray", "--workers", "2"]) == 0

    def listing(root: Path) -> list[str]:
        return sorted(str(p.relative_to(root)) for p in root.rglob("*") if p.is_file())

    assert listing(povray_out) == listing(mujoco_out)
    assert "videos/video_00002.mp4" in listing(povray_out)
    # Same scene, same truth: annotations, masks and questions are byte-identical; the
    # ground truth (camera included) only adds the renderer and its look.
    for name in ("annotations/annotation_00002.json", "masks/proposal_00002.json", "questions.json"):
        assert (povray_out / name).read_bytes() == (mujoco_out / name).read_bytes(), name
    truth_m = json.loads((mujoco_out / "ground_truth/scene_00002.json").read_text())
    truth_p = json.loads((povray_out / "ground_truth/scene_00002.json").read_text())
    assert truth_p.pop("renderer")["name"] == "povray"
    assert truth_p == truth_m and "camera" in truth_p
    frames_m, frames_p = read_mp4(mujoco_out / "videos/video_00002.mp4"), read_mp4(povray_out / "videos/video_00002.mp4")
    assert frames_p.shape == frames_m.shape == (128, 320, 480, 3)
    assert np.abs(frames_p.astype(int) - frames_m.astype(int)).mean() > 10  # another renderer drew it


def test_missing_povray_is_a_one_line_error(tmp_path, monkeypatch, capsys):
    empty = tmp_path / "bin"
    empty.mkdir()
    monkeypatch.setenv("PATH", str(empty))
    out = tmp_path / "out"
    code = main(["synth", "--out", str(out), "--scenes", "1", "--seed", "1", "--renderer", "povray"])
    error = capsys.readouterr().err.strip()
    assert code == 2
    assert len(error.splitlines()) == 1 and "povray" in error and "apt-get install -y povray" in error
    assert not out.exists() or not any(out.rglob("*.mp4"))
