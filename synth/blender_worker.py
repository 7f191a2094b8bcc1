"""Child process of synth.blender: build a scene description in Blender and render it with Cycles.

    python -m synth.blender_worker scene.json    (run in the directory holding scene.json)

Writes ``frame_NNNN.png`` (8-bit sRGB, Standard view transform) per frame into
the working directory, and ``timings.json``: set-up and per-frame CPU and wall
seconds of this process (bench/bench_blender.py reads them). The only module
of ours that imports ``bpy``; it takes everything from the JSON (synth.blender.scene_description documents the keys)
and uses no numpy, so bpy's numpy-1.x build does not matter here.
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import bpy  # first: importing bpy makes Blender's own modules (bmesh, mathutils) importable
import bmesh  # noqa: I001
from mathutils import Matrix


def _settings(description: dict) -> bpy.types.Scene:
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    cycles = scene.cycles
    cycles.device = "CPU"
    settings = description["cycles"]
    cycles.samples = settings["samples"]
    cycles.use_adaptive_sampling = False
    cycles.use_denoising = settings["denoise"]
    cycles.denoiser = "OPENIMAGEDENOISE"
    cycles.denoising_use_gpu = False
    cycles.denoising_quality = "FAST"
    cycles.denoising_prefilter = "FAST"
    bounces = settings["bounces"]
    cycles.max_bounces = bounces["max"]
    cycles.diffuse_bounces = bounces["diffuse"]
    cycles.glossy_bounces = bounces["glossy"]
    cycles.transmission_bounces = 0
    cycles.volume_bounces = 0
    cycles.transparent_max_bounces = 0
    cycles.caustics_reflective = False
    cycles.caustics_refractive = False
    render = scene.render
    render.threads_mode = "FIXED"
    render.threads = settings["threads"]
    render.use_persistent_data = True  # keep the BVH and shaders between frames; only poses change
    render.resolution_x = description["width"]
    render.resolution_y = description["height"]
    render.resolution_percentage = 100
    render.image_settings.file_format = "PNG"
    render.image_settings.color_mode = "RGB"
    render.image_settings.color_depth = "8"
    scene.view_settings.view_transform = "Standard"  # plain sRGB, no filmic/AgX tone curve
    scene.view_settings.look = "None"
    return scene


def _matrix(location, rotation) -> Matrix:
    matrix = Matrix([list(row) + [0.0] for row in rotation] + [[0.0, 0.0, 0.0, 1.0]])
    matrix.translation = location
    return matrix


def _link(scene, name: str, data) -> bpy.types.Object:
    obj = bpy.data.objects.new(name, data)
    scene.collection.objects.link(obj)
    return obj


def _camera(scene, camera: dict) -> None:
    data = bpy.data.cameras.new("camera")
    data.sensor_fit = "HORIZONTAL"
    data.sensor_width = camera["sensor_width_mm"]
    data.lens = camera["lens_mm"]
    data.shift_x = camera["shift_x"]
    data.shift_y = camera["shift_y"]
    data.clip_start = 0.05
    data.clip_end = 200.0
    obj = _link(scene, "camera", data)
    obj.matrix_world = _matrix(camera["location"], camera["rotation"])
    scene.camera = obj


def _world(scene, world: dict) -> None:
    data = bpy.data.worlds.new("world")
    data.use_nodes = True
    background = data.node_tree.nodes["Background"]
    background.inputs["Color"].default_value = (*world["rgb"], 1.0)
    background.inputs["Strength"].default_value = world["strength"]
    scene.world = data


def _light(scene, index: int, light: dict) -> None:
    if light["kind"] == "sun":
        data = bpy.data.lights.new(f"light_{index}", "SUN")
        data.energy = light["strength"]
        data.angle = light["angle"]
    else:
        data = bpy.data.lights.new(f"light_{index}", "AREA")
        data.energy = light["power"]
        data.shape = "SQUARE"
        data.size = light["size"]
    data.color = light["rgb"]
    obj = _link(scene, f"light_{index}", data)
    obj.matrix_world = _matrix(light["location"], light["rotation"])


def _principled(name: str) -> tuple[bpy.types.Material, bpy.types.Node]:
    material = bpy.data.materials.new(name)
    material.use_nodes = True
    return material, material.node_tree.nodes["Principled BSDF"]


def _floor(scene, floor: dict) -> None:
    material, bsdf = _principled("floor")
    bsdf.inputs["Roughness"].default_value = floor["roughness"]
    bsdf.inputs["Metallic"].default_value = 0.0
    nodes, links = material.node_tree.nodes, material.node_tree.links
    if floor["kind"] == "plain":
        bsdf.inputs["Base Color"].default_value = (*floor["rgb"], 1.0)
    else:
        coordinates = nodes.new("ShaderNodeTexCoord")
        mapping = nodes.new("ShaderNodeMapping")
        # Mapping (point): out = scale * in + location; the pattern repeats every floor["scale"] metres.
        mapping.inputs["Scale"].default_value = [1.0 / floor["scale"]] * 3
        mapping.inputs["Location"].default_value = [floor["offset"][0] / floor["scale"], floor["offset"][1] / floor["scale"], 0.0]
        links.new(coordinates.outputs["Object"], mapping.inputs["Vector"])
        if floor["kind"] == "clevrer":
            texture = nodes.new("ShaderNodeTexImage")
            texture.image = bpy.data.images.load(str(Path(floor["image"]).resolve()))
            texture.extension = "MIRROR"  # tiles without seams
            tint = nodes.new("ShaderNodeMix")
            tint.data_type = "RGBA"
            tint.blend_type = "MULTIPLY"
            tint.inputs["Factor"].default_value = 1.0
            links.new(mapping.outputs["Vector"], texture.inputs["Vector"])
            links.new(texture.outputs["Color"], tint.inputs[6])  # A (colour)
            tint.inputs[7].default_value = (*floor["tint"], 1.0)  # B (colour)
            links.new(tint.outputs[2], bsdf.inputs["Base Color"])  # Result (colour)
        elif floor["kind"] == "noise":
            noise = nodes.new("ShaderNodeTexNoise")
            noise.inputs["Scale"].default_value = 1.0
            ramp = nodes.new("ShaderNodeValToRGB")
            ramp.color_ramp.elements[0].position = 0.35
            ramp.color_ramp.elements[0].color = (*floor["rgb2"], 1.0)
            ramp.color_ramp.elements[1].position = 0.65
            ramp.color_ramp.elements[1].color = (*floor["rgb"], 1.0)
            links.new(mapping.outputs["Vector"], noise.inputs["Vector"])
            links.new(noise.outputs["Fac"], ramp.inputs["Fac"])
            links.new(ramp.outputs["Color"], bsdf.inputs["Base Color"])
        else:
            checker = nodes.new("ShaderNodeTexChecker")
            checker.inputs["Scale"].default_value = 1.0  # one square per floor["scale"] metres
            checker.inputs["Color1"].default_value = (*floor["rgb"], 1.0)
            checker.inputs["Color2"].default_value = (*floor["rgb2"], 1.0)
            links.new(mapping.outputs["Vector"], checker.inputs["Vector"])
            links.new(checker.outputs["Color"], bsdf.inputs["Base Color"])
    mesh = bpy.data.meshes.new("floor")
    half = floor["size"] / 2.0
    mesh.from_pydata([(-half, -half, 0.0), (half, -half, 0.0), (half, half, 0.0), (-half, half, 0.0)], [], [(0, 1, 2, 3)])
    mesh.materials.append(material)
    _link(scene, "floor", mesh)


def _primitive(name: str, shape: str, half: float, segments: dict) -> bpy.types.Mesh:
    """Mesh in the body frame, as MuJoCo's geoms: sphere radius, cube half side, cylinder radius and half length (along z)."""
    mesh = bpy.data.meshes.new(name)
    built = bmesh.new()
    if shape == "sphere":
        around, rings = segments["sphere"]
        bmesh.ops.create_uvsphere(built, u_segments=around, v_segments=rings, radius=half)
    elif shape == "cube":
        bmesh.ops.create_cube(built, size=2.0 * half)
    else:
        bmesh.ops.create_cone(built, cap_ends=True, segments=segments["cylinder"], radius1=half, radius2=half, depth=2.0 * half)
    built.to_mesh(mesh)
    built.free()
    for polygon in mesh.polygons:
        # Smooth the curved surfaces; cube faces and cylinder caps stay flat.
        polygon.use_smooth = shape == "sphere" or (shape == "cylinder" and abs(polygon.normal.z) < 0.5)
    return mesh


def _objects(scene, description: dict) -> list[bpy.types.Object]:
    objects = []
    for spec in description["objects"]:
        material, bsdf = _principled(spec["name"])
        bsdf.inputs["Base Color"].default_value = (*spec["rgb"], 1.0)
        bsdf.inputs["Metallic"].default_value = spec["metallic"]
        bsdf.inputs["Roughness"].default_value = spec["roughness"]
        bsdf.inputs["Specular IOR Level"].default_value = spec["specular"]
        mesh = _primitive(spec["name"], spec["shape"], spec["half_size"], description["segments"])
        mesh.materials.append(material)
        objects.append(_link(scene, spec["name"], mesh))
    return objects


def main(path: str) -> None:
    wall, cpu = time.perf_counter(), time.process_time()
    description = json.loads(Path(path).read_text())
    scene = _settings(description)
    _camera(scene, description["camera"])
    _world(scene, description["world"])
    for index, light in enumerate(description["lights"]):
        _light(scene, index, light)
    _floor(scene, description["floor"])
    objects = _objects(scene, description)
    timings = {"setup_wall_s": time.perf_counter() - wall, "setup_cpu_s": time.process_time() - cpu, "frames": []}
    for frame, poses in enumerate(description["poses"]):
        wall, cpu = time.perf_counter(), time.process_time()
        for obj, pose in zip(objects, poses):
            obj.matrix_world = Matrix(pose)
        scene.cycles.seed = frame  # fresh sampling noise per frame, as an animation render has
        scene.render.filepath = str(Path(f"frame_{frame:04d}.png").resolve())
        bpy.ops.render.render(write_still=True)
        timings["frames"].append({"wall_s": time.perf_counter() - wall, "cpu_s": time.process_time() - cpu})
        print(f"frame {frame} done", file=sys.stderr, flush=True)
    Path("timings.json").write_text(json.dumps(timings))


if __name__ == "__main__":
    main(sys.argv[1])
