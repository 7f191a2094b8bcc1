"""The Blender Cycles renderer (synth/blender.py, synth/blender_worker.py, synth/blender_look.py):
Blender's own camera math agrees with world.camera.project, a render puts every object where
MuJoCo's does, the look family is seeded and varied, area lights are calibrated against a sun,
and a missing bpy is a one-line error.

The tests that render need the bpy module (`make render`, part of `make test`); without it
they fail with the install hint, they do not skip.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import pytest

import synth.blender
from physmind.cli import main
from synth.blender import (
    AREA_POWER_TO_IRRADIANCE,
    blender_camera,
    render_description,
    render_scene_blender,
    scene_blender_look,
    scene_description,
    srgb_to_linear,
)
from synth.blender_look import (
    BLENDER_FLOORS,
    METAL_ROUGHNESS,
    RUBBER_ROUGHNESS,
    BlenderFloor,
    BlenderLight,
    BlenderLook,
    blender_look_seed_sequence,
    sample_blender_look,
)
from synth.povray import floor_point_in_view
from synth.render import render_scene
from synth.scene import camera_from_pose
from synth.simulate import simulate
from tests.synth.test_povray import TEST_PAINTS, _colour_labels, _test_scene
from world.camera import project
from world.types import COLORS, Camera

# Runs in a child process (bpy keeps global state): Blender's own projection of world points
# through the camera that synth.blender_worker builds, as pixel-centre coordinates (u right, v down).
_BLENDER_PROJECTION = """
import json, sys
import bpy
from bpy_extras.object_utils import world_to_camera_view
from mathutils import Vector
from synth.blender_worker import _camera, _settings
description, points = json.loads(sys.stdin.read())
scene = _settings(description)
_camera(scene, description["camera"])
pixels = []
for point in points:
    ndc = world_to_camera_view(scene, scene.camera, Vector(point))
    pixels.append([ndc.x * description["width"] - 0.5, (1.0 - ndc.y) * description["height"] - 0.5])
print(json.dumps(pixels))
"""


def _blender_pixels(camera: Camera, points: np.ndarray) -> np.ndarray:
    description = {"width": camera.width, "height": camera.height, "camera": blender_camera(camera),
                   "cycles": {"samples": 1, "denoise": False, "threads": 1, "bounces": synth.blender.CYCLES_BOUNCES}}
    run = subprocess.run([sys.executable, "-c", _BLENDER_PROJECTION], input=json.dumps([description, points.tolist()]),
                         capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr[-2000:]
    return np.array(json.loads(run.stdout.strip().splitlines()[-1]))


def test_blender_camera_projects_like_ours():
    rng = np.random.default_rng(4)
    centred = camera_from_pose(5.5, 38.0, -7.0, 34.0, np.array([0.2, -0.1, 0.0]))
    # An off-centre principal point exercises Blender's lens shift.
    shifted = Camera(width=centred.width, height=centred.height, fx=centred.fx, fy=centred.fy, cx=centred.cx + 23.0,
                     cy=centred.cy - 11.0, position=centred.position, rotation=centred.rotation)
    for camera in (centred, shifted):
        points = np.column_stack([rng.uniform(-2.5, 2.5, 12), rng.uniform(-2.0, 2.0, 12), rng.uniform(0.0, 0.8, 12)])
        ours = project(camera, points)
        inside = (ours[:, 0] > 0) & (ours[:, 0] < camera.width) & (ours[:, 1] > 0) & (ours[:, 1] < camera.height)
        assert inside.sum() >= 6, "the test needs points in view"
        theirs = _blender_pixels(camera, points)
        error = np.linalg.norm(theirs - ours, axis=1).max()
        assert error < 0.05, f"Blender's projection is {error:.3f} px from world.camera.project"


def _test_look(camera: Camera) -> BlenderLook:
    """Plain grey floor, a hard sun from behind the camera (shadows hide behind the objects), rubber paints."""
    target = np.array(floor_point_in_view(camera))
    towards_camera = np.asarray(camera.position) - target
    sun = BlenderLight("sun", tuple(towards_camera / np.linalg.norm(towards_camera)), 2.5, (1.0, 1.0, 1.0),
                       math.radians(0.5), 0.0)
    return BlenderLook(floor=BlenderFloor("plain", (0.5, 0.5, 0.5), (0.5, 0.5, 0.5), 1.0, (0.0, 0.0), 0.8),
                       lights=(sun,), background_rgb=(0.8, 0.8, 0.8), background_strength=0.3, metal_roughness=0.2,
                       rubber_roughness=0.8, rubber_specular=0.3,
                       paints=tuple(TEST_PAINTS.get(c, (0.5, 0.5, 0.5)) for c in COLORS))


@pytest.mark.slow
def test_blender_render_matches_mujoco_silhouettes():
    spec = _test_scene()
    sim = simulate(spec, horizon_frames=4)
    _, instance = render_scene(spec, sim, frames=4)
    rgb = render_scene_blender(spec, sim, _test_look(spec.camera), frames=4, threads=2)
    assert rgb.shape == (4, spec.camera.height, spec.camera.width, 3) and rgb.dtype == np.uint8
    assert np.linalg.norm(sim.positions[3, 0] - sim.positions[0, 0]) > 0.05  # frame 3 has a moved pose
    for frame in (0, 3):
        labels = _colour_labels(rgb[frame], spec)
        for obj in spec.objects:
            truth, found = instance[frame] == obj.object_id, labels == obj.object_id
            assert truth.sum() > 300, "the test scene must show every object"
            offset = float(np.linalg.norm(np.argwhere(truth).mean(axis=0) - np.argwhere(found).mean(axis=0)))
            iou = (truth & found).sum() / (truth | found).sum()
            assert offset <= 2.0, f"frame {frame} object {obj.object_id}: centroid {offset:.2f} px from MuJoCo's"
            assert iou > 0.85, f"frame {frame} object {obj.object_id}: silhouette IoU {iou:.3f}"


def test_scene_description_is_json_and_follows_the_simulation():
    spec = _test_scene()
    sim = simulate(spec, horizon_frames=3)
    look = scene_blender_look(21, 3)
    description = json.loads(json.dumps(scene_description(spec, sim, look, 3)))
    poses = np.array(description["poses"])
    assert poses.shape == (3, len(spec.objects), 4, 4)
    assert np.allclose(poses[:, :, :3, 3], sim.positions[:3])
    assert np.allclose(poses[:, :, :3, :3] @ np.swapaxes(poses[:, :, :3, :3], -1, -2), np.eye(3), atol=1e-9)
    by_name = {o["name"]: o for o in description["objects"]}
    for obj in spec.objects:
        entry = by_name[f"object_{obj.object_id}"]
        assert entry["rgb"] == srgb_to_linear(look.paint(obj.color))
        assert entry["metallic"] == (1.0 if obj.material == "metal" else 0.0)
    # sRGB 0.5 is linear 0.214 (IEC 61966-2-1).
    assert math.isclose(srgb_to_linear([0.5])[0], 0.21404, abs_tol=1e-5)


def test_blender_look_family_is_seeded_varied_and_physical():
    looks = [scene_blender_look(11, index) for index in range(60)]
    assert scene_blender_look(11, 5) == looks[5]
    assert sample_blender_look(np.random.default_rng(blender_look_seed_sequence(12, 5))) != looks[5]
    assert {look.floor.kind for look in looks} == set(BLENDER_FLOORS)  # the CLEVRER image among them
    assert {len(look.lights) for look in looks} == {1, 2, 3}
    assert {look.lights[0].kind for look in looks} == {"sun", "area"}
    sun_angles = [math.degrees(light.size) for look in looks for light in look.lights if light.kind == "sun"]
    assert min(sun_angles) < 2.0 and max(sun_angles) > 8.0  # hard and soft shadows
    for look in looks:
        assert METAL_ROUGHNESS[0] <= look.metal_roughness <= METAL_ROUGHNESS[1]
        assert RUBBER_ROUGHNESS[0] <= look.rubber_roughness <= RUBBER_ROUGHNESS[1]


# A white-ish matte floor lit from straight above, seen from above: the pixel value (linear)
# is albedo x irradiance / pi whichever light gives the irradiance.
def _floor_brightness(light: dict) -> float:
    description = {
        "width": 24, "height": 16,
        "cycles": {"samples": 16, "denoise": False, "threads": 2, "bounces": synth.blender.CYCLES_BOUNCES},
        "camera": blender_camera(camera_from_pose(3.0, 89.0, 0.0, 30.0, np.zeros(3))),
        "world": {"rgb": [0.0, 0.0, 0.0], "strength": 0.0},
        "lights": [light],
        "floor": {"kind": "plain", "rgb": [0.2, 0.2, 0.2], "rgb2": [0.2, 0.2, 0.2], "tint": [1.0, 1.0, 1.0], "scale": 1.0,
                  "offset": [0.0, 0.0], "roughness": 1.0, "image": None, "size": 40.0},
        "objects": [], "segments": {"sphere": [8, 4], "cylinder": 8}, "poses": [[]],
    }
    with tempfile.TemporaryDirectory() as tmp:
        image = render_description(description, Path(tmp))
    return float(np.mean(srgb_to_linear(image[0, 4:12, 8:16].reshape(-1) / 255.0)))


def test_area_light_matches_sun_irradiance():
    down = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]  # local -Z (the light's direction) points down
    irradiance, distance = 2.0, 8.0
    sun = _floor_brightness({"kind": "sun", "location": [0.0, 0.0, 10.0], "rotation": down, "strength": irradiance,
                             "angle": 0.01, "rgb": [1.0, 1.0, 1.0]})
    area = _floor_brightness({"kind": "area", "location": [0.0, 0.0, distance], "rotation": down,
                              "power": irradiance * distance**2 / AREA_POWER_TO_IRRADIANCE, "size": 0.5,
                              "rgb": [1.0, 1.0, 1.0]})
    assert math.isclose(sun, 0.2 * irradiance / math.pi, rel_tol=0.1), sun
    assert math.isclose(area, sun, rel_tol=0.1), (area, sun)


def test_missing_bpy_is_a_one_line_error(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(synth.blender, "bpy_available", lambda: False)
    out = tmp_path / "out"
    code = main(["synth", "--out", str(out), "--scenes", "1", "--seed", "1", "--renderer", "blender"])
    error = capsys.readouterr().err.strip()
    assert code == 2
    assert len(error.splitlines()) == 1 and "bpy" in error and "pip install --no-deps bpy==" in error
    assert not out.exists() or not any(out.rglob("*.mp4"))
