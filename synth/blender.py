"""Render a simulated scene with Blender's Cycles path tracer (the renderer CLEVRER itself used).

The same SceneSpec and SimResult that synth.render draws with MuJoCo's OpenGL
renderer, with the same camera pose and intrinsics, path-traced by Cycles on
the CPU in a look of synth.blender_look's family. Instance masks are not drawn
here: the geometry is the same, so the annotations keep MuJoCo's segmentation
(synth.render) and the ground truth does not change.

Two halves:

* ``scene_description`` (pure, no Blender): the whole scene as a JSON-able
  dict in Blender's terms: camera (location, rotation, lens, shift), lights,
  floor, materials (linear colours), primitives and each frame's 4x4 poses.
* ``render_scene_blender``: writes that description to a temporary directory
  and runs ``python -m synth.blender_worker`` (the only module that imports
  ``bpy``) in a child process, which builds the scene and writes one PNG per
  frame; the PNGs are read back as (F, H, W, 3) uint8. The child keeps
  Blender's global state, its threads and its memory out of this process, and
  a hang is cut by a timeout.

Camera: our Camera is OpenCV's (columns of ``rotation`` = right, down, forward
in the world). A Blender camera looks along its local -Z with +Y up, so its
rotation has columns right, -down, -forward. Intrinsics: horizontal sensor fit
with ``lens / sensor_width = fx / W``; Blender puts the principal point at the
image centre ((W - 1) / 2 in pixel-centre coordinates) plus ``shift`` in units
of the larger image side. Square pixels only (fx == fy).
"""

from __future__ import annotations

import importlib.util
import json
import math
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
from PIL import Image

from synth.blender_look import BlenderLight, BlenderLook, blender_look_seed_sequence, sample_blender_look
from synth.looks import CLEVRER_FLOOR_FILE, clevrer_floor_png
from synth.povray import floor_point_in_view
from synth.scene import SceneSpec
from synth.simulate import SimResult
from world.scene3d.types import quaternion_matrix
from world.types import Camera

BPY_VERSION = "5.0.1"  # pinned in pyproject.toml's "render" extra and constraints.txt
BPY_INSTALL_HINT = f"install it: .venv/bin/pip install --no-deps bpy=={BPY_VERSION} (or `make render`)"
# Cycles settings measured for speed on 2 CPU cores (docs/benchmarks.md, "A third renderer: Blender Cycles").
CYCLES_SAMPLES = 2  # paths per pixel before denoising
CYCLES_DENOISE = True  # OpenImageDenoise (ships in bpy), fast quality and prefilter
CYCLES_BOUNCES = {"max": 3, "diffuse": 1, "glossy": 2}  # metal mirrors the floor and its neighbours once
SENSOR_WIDTH_MM = 36.0  # any width works: only lens / sensor_width matters
FLOOR_SIZE = 80.0  # m, side of the square floor mesh (reaches the horizon in every synth camera)
SPHERE_SEGMENTS = (48, 24)  # uv sphere: segments around, rings
CYLINDER_SEGMENTS = 48
BLENDER_TIMEOUT_PER_FRAME = 120.0  # s; a frame never takes this long unless Blender hangs
# Cycles' area light of power P (W) gives an on-axis irradiance of AREA_POWER_TO_IRRADIANCE x P / d^2 (W/m^2)
# at distance d >> its size: Blender's watts are not radiometric (measured against a sun of known strength,
# tests/synth/test_blender.py::test_area_light_matches_sun_irradiance).
AREA_POWER_TO_IRRADIANCE = 1.0 / math.pi


def bpy_available() -> bool:
    """True if the ``bpy`` module (Blender as a Python module) is installed."""
    return importlib.util.find_spec("bpy") is not None


def require_bpy() -> None:
    """FileNotFoundError (one line, how to install) if ``bpy`` is missing."""
    if not bpy_available():
        raise FileNotFoundError(f"blender: the bpy module (Blender as a Python module) is not installed; {BPY_INSTALL_HINT}")


def srgb_to_linear(rgb) -> list[float]:
    """sRGB 0..1 -> linear 0..1 (the IEC 61966-2-1 transfer function), as Cycles' colours take them."""
    values = np.asarray(rgb, dtype=float)
    linear = np.where(values <= 0.04045, values / 12.92, ((values + 0.055) / 1.055) ** 2.4)
    return [float(v) for v in linear]


def blender_camera(camera: Camera) -> dict:
    """Blender camera parameters of a world.types.Camera: location (3,), rotation (3, 3) columns =
    camera X, Y, Z in the world, lens and sensor width (mm), shift_x, shift_y (units of the larger side)."""
    if not math.isclose(camera.fx, camera.fy, rel_tol=1e-6):
        raise ValueError(f"camera: Blender renders square pixels; fx {camera.fx} != fy {camera.fy}")
    rotation = np.asarray(camera.rotation, dtype=float) @ np.diag([1.0, -1.0, -1.0])
    larger = float(max(camera.width, camera.height))
    return {
        "location": [float(v) for v in camera.position],
        "rotation": rotation.tolist(),
        "lens_mm": SENSOR_WIDTH_MM * camera.fx / camera.width,
        "sensor_width_mm": SENSOR_WIDTH_MM,
        "shift_x": ((camera.width - 1) / 2.0 - camera.cx) / larger,
        "shift_y": (camera.cy - (camera.height - 1) / 2.0) / larger,
    }


def _facing(direction) -> list[list[float]]:
    """(3, 3) rotation whose local +Z is ``direction`` (a Blender light shines along its local -Z)."""
    z = np.asarray(direction, dtype=float)
    z = z / np.linalg.norm(z)
    helper = np.array([0.0, 0.0, 1.0]) if abs(z[2]) < 0.99 else np.array([1.0, 0.0, 0.0])
    x = np.cross(helper, z)
    x /= np.linalg.norm(x)
    return np.column_stack([x, np.cross(z, x), z]).tolist()


def _light(light: BlenderLight, target) -> dict:
    rotation = _facing(light.direction)
    rgb = [float(v) for v in light.tint]
    if light.kind == "sun":
        return {"kind": "sun", "location": [float(v) for v in np.asarray(target) + 10.0 * np.asarray(light.direction)],
                "rotation": rotation, "strength": light.irradiance, "angle": light.size, "rgb": rgb}
    location = np.asarray(target) + light.distance * np.asarray(light.direction)
    power = light.irradiance * light.distance**2 / AREA_POWER_TO_IRRADIANCE
    return {"kind": "area", "location": [float(v) for v in location], "rotation": rotation, "power": float(power),
            "size": light.size, "rgb": rgb}


def _floor(look: BlenderLook) -> dict:
    floor = look.floor
    return {
        "kind": floor.kind,
        "rgb": srgb_to_linear(floor.rgb),
        "rgb2": srgb_to_linear(floor.rgb2),
        # The CLEVRER image keeps its own shades, tinted by the floor colour relative to its brightest channel.
        "tint": [float(v) for v in np.asarray(srgb_to_linear(floor.rgb)) / max(srgb_to_linear(floor.rgb))],
        "scale": floor.scale,
        "offset": list(floor.offset),
        "roughness": floor.roughness,
        "image": CLEVRER_FLOOR_FILE if floor.kind == "clevrer" else None,
        "size": FLOOR_SIZE,
    }


def _pose(position, quaternion) -> list[list[float]]:
    matrix = np.eye(4)
    matrix[:3, :3] = quaternion_matrix(tuple(quaternion))
    matrix[:3, 3] = position
    return matrix.tolist()


def scene_description(spec: SceneSpec, sim: SimResult, look: BlenderLook, frames: int,
                      samples: int = CYCLES_SAMPLES, denoise: bool = CYCLES_DENOISE, threads: int = 1) -> dict:
    """Everything the Blender worker needs, JSON-able: image size, Cycles settings, camera, world,
    lights, floor, one material per object (linear base colour, metallic, roughness), primitives
    (shape, half size m) and ``poses`` (frames, objects, 4, 4) world-from-body matrices."""
    if frames < 1 or frames > sim.positions.shape[0]:
        raise ValueError(f"frames: expected 1..{sim.positions.shape[0]}, got {frames}")
    target = floor_point_in_view(spec.camera)
    by_id = {o.object_id: o for o in spec.objects}
    objects = []
    for oid in sim.object_ids:
        obj = by_id[oid]
        metal = obj.material == "metal"
        objects.append({
            "name": f"object_{oid}",
            "shape": obj.shape,
            "half_size": float(obj.half_size),
            "rgb": srgb_to_linear(look.paint(obj.color)),
            "metallic": 1.0 if metal else 0.0,
            "roughness": look.metal_roughness if metal else look.rubber_roughness,
            "specular": 0.5 if metal else look.rubber_specular,
        })
    poses = [[_pose(sim.positions[f, k], sim.quaternions[f, k]) for k in range(len(sim.object_ids))]
             for f in range(frames)]
    return {
        "width": spec.camera.width,
        "height": spec.camera.height,
        "cycles": {"samples": int(samples), "denoise": bool(denoise), "threads": int(threads), "bounces": CYCLES_BOUNCES},
        "camera": blender_camera(spec.camera),
        "world": {"rgb": srgb_to_linear(look.background_rgb), "strength": look.background_strength},
        "lights": [_light(light, target) for light in look.lights],
        "floor": _floor(look),
        "objects": objects,
        "segments": {"sphere": list(SPHERE_SEGMENTS), "cylinder": CYLINDER_SEGMENTS},
        "poses": poses,
    }


def render_description(description: dict, work: Path) -> np.ndarray:
    """Run the Blender worker on ``description`` in directory ``work``; (F, H, W, 3) uint8 RGB.
    FileNotFoundError if bpy is missing; RuntimeError (with Blender's last message) if it fails."""
    require_bpy()
    count = len(description["poses"])
    if description["floor"]["image"] is not None:
        (work / description["floor"]["image"]).write_bytes(clevrer_floor_png())
    (work / "scene.json").write_text(json.dumps(description))
    try:
        run = subprocess.run([sys.executable, "-m", "synth.blender_worker", "scene.json"], cwd=work,
                             stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                             timeout=BLENDER_TIMEOUT_PER_FRAME * count)
    except subprocess.TimeoutExpired:
        raise RuntimeError(f"blender: timed out after {BLENDER_TIMEOUT_PER_FRAME * count:.0f} s") from None
    if run.returncode != 0:
        lines = [line for line in run.stderr.decode(errors="replace").splitlines() if line.strip()]
        raise RuntimeError(f"blender: exit code {run.returncode}: {lines[-1] if lines else 'no message'}")
    outputs = [work / f"frame_{frame:04d}.png" for frame in range(count)]
    missing = [p.name for p in outputs if not p.exists()]
    if missing:
        raise RuntimeError(f"blender wrote {count - len(missing)} of {count} frames (first missing: {missing[0]})")
    return np.stack([np.asarray(Image.open(path).convert("RGB")) for path in outputs])


def render_scene_blender(spec: SceneSpec, sim: SimResult, look: BlenderLook, frames: int | None = None,
                         threads: int = 1) -> np.ndarray:
    """Path-trace the first ``frames`` frames (default: the observed ones) in look ``look`` with
    ``threads`` Cycles threads. Returns (F, H, W, 3) uint8 RGB."""
    count = spec.observed_frames if frames is None else int(frames)
    if threads < 1:
        raise ValueError(f"threads: expected >= 1, got {threads}")
    description = scene_description(spec, sim, look, count, threads=threads)
    with tempfile.TemporaryDirectory(prefix="physmind-blender-") as tmp:
        try:
            return render_description(description, Path(tmp))
        except RuntimeError as error:
            raise RuntimeError(f"scene {spec.scene_index}: {error}") from None


def scene_blender_look(seed: int, index: int) -> BlenderLook:
    """The Blender look of scene ``index`` of dataset ``seed`` (its own stream)."""
    return sample_blender_look(np.random.default_rng(blender_look_seed_sequence(seed, index)))
