"""Render a simulated scene with POV-Ray 3.7, a ray tracer that shares no code with MuJoCo's renderer.

The same SceneSpec and SimResult that synth.render draws with MuJoCo's OpenGL
renderer, with the same camera pose and intrinsics, ray-traced in a look of
synth.povray_look's family (true reflections on metal, area or point lights,
an image-mapped or textured floor, a sky dome). Instance masks are not drawn
here: the geometry is the same, so the annotations keep MuJoCo's segmentation
(synth.render) and the ground truth does not change.

Frames: one scene file ``scene.pov`` plus one include per frame
(``frame_NNNN.inc``, the objects' poses), rendered as a POV-Ray animation
(``+KFI/+KFF``, subset ``+SF/+EF``) by ``processes`` concurrent single-threaded
``povray`` runs, each on its own range of frames, into PPM files read back
with numpy.

Coordinates: POV-Ray is left-handed with y up. A world point (x, y, z)
(right-handed, z up) is POV-Ray's <x, z, y>; swapping two axes turns a
right-handed frame into a left-handed one, so the scene is the same, not
mirrored. The camera is written with explicit direction/right/up vectors (no
look_at): direction = forward (unit), up = image-up x H / fy, right =
image-right x W / fx, which fixes the pinhole with the principal point at the
image centre (as synth.scene's cameras have it).
"""

from __future__ import annotations

import shutil
import subprocess
import tempfile
from pathlib import Path

import numpy as np

from synth.looks import CLEVRER_FLOOR_FILE, clevrer_floor_png
from synth.povray_look import AREA_LIGHT_SAMPLES, PovFinish, PovLight, PovLook, povray_look_seed_sequence, sample_povray_look
from synth.scene import SceneSpec
from synth.simulate import SimResult
from world.scene3d.types import quaternion_matrix
from world.types import Camera

POVRAY_BINARY = "povray"
POVRAY_INSTALL_HINT = "install it: sudo apt-get install -y povray (or `make install` as root)"
ANTIALIAS_THRESHOLD = 0.3  # POV-Ray adaptive supersampling (+A): modest, only where neighbours differ
ANTIALIAS_DEPTH = 2  # +R: up to 2 x 2 sub-samples per pixel
MAX_TRACE_LEVEL = 4  # reflections of reflections, enough for metal next to metal
POVRAY_TIMEOUT_PER_FRAME = 60.0  # s; a frame never takes this long unless POV-Ray hangs
# Swap world y and z: world (right-handed, z up) -> POV-Ray (left-handed, y up).
WORLD_TO_POV = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, 1.0, 0.0]])


def povray_path() -> str:
    """The povray executable; FileNotFoundError (one line, how to install) if it is missing."""
    path = shutil.which(POVRAY_BINARY)
    if path is None:
        raise FileNotFoundError(f"povray: the POV-Ray executable was not found on PATH; {POVRAY_INSTALL_HINT}")
    return path


def _vec(values) -> str:
    return "<" + ", ".join(f"{float(v):.10g}" for v in values) + ">"


def _pov(point) -> np.ndarray:
    """(3,) world vector -> POV-Ray vector."""
    return WORLD_TO_POV @ np.asarray(point, dtype=float)


def camera_statement(camera: Camera) -> str:
    """POV-Ray camera of a world.types.Camera (OpenCV axes: rotation columns right, down, forward)."""
    rotation = np.asarray(camera.rotation, dtype=float)
    right, down, forward = rotation[:, 0], rotation[:, 1], rotation[:, 2]
    return (
        "camera { perspective\n"
        f"  location {_vec(_pov(camera.position))}\n"
        f"  direction {_vec(_pov(forward))}\n"
        f"  right {_vec(_pov(right) * camera.width / camera.fx)}\n"
        f"  up {_vec(_pov(-down) * camera.height / camera.fy)}\n"
        "}\n"
    )


def _finish(finish: PovFinish, ambient: float) -> str:
    reflection = f" metallic reflection {{ {finish.reflection:.5g} metallic }}" if finish.reflection > 0 else ""
    return (
        f"finish {{ ambient {ambient:.5g} diffuse {finish.diffuse:.5g} specular {finish.specular:.5g} "
        f"roughness {finish.roughness:.5g}{reflection} }}"
    )


def _floor(look: PovLook) -> str:
    floor = look.floor
    finish = f"finish {{ ambient {look.ambient:.5g} diffuse 0.85 specular {floor.specular:.5g} roughness 0.05"
    finish += f" reflection {floor.reflection:.5g} }}" if floor.reflection > 0 else " }"
    shift = f"translate {_vec([floor.offset[0], 0.0, floor.offset[1]])}"
    if floor.kind == "clevrer":
        # image_map spans the unit square of the x-y plane; lay it on the floor (x-z plane).
        pigment = (f'pigment {{ image_map {{ png "{CLEVRER_FLOOR_FILE}" interpolate 2 }} '
                   f"rotate x*90 scale {floor.scale:.5g} {shift} }}")
    elif floor.kind == "plain":
        pigment = f"pigment {{ srgb {_vec(floor.rgb)} }}"
    elif floor.kind == "noise":
        pigment = (f"pigment {{ granite color_map {{ [0 srgb {_vec(floor.rgb)}] [1 srgb {_vec(floor.rgb2)}] }} "
                   f"scale {floor.scale:.5g} {shift} }}")
    else:
        pigment = f"pigment {{ checker srgb {_vec(floor.rgb)} srgb {_vec(floor.rgb2)} scale {floor.scale:.5g} {shift} }}"
    return f"plane {{ y, 0 texture {{ {pigment} {finish} }} }}\n"


def _light(light: PovLight) -> str:
    text = f"light_source {{ {_vec(_pov(light.position))} color rgb {_vec(light.rgb)}"
    if light.area_size > 0:
        n = AREA_LIGHT_SAMPLES
        text += (f" area_light {_vec([light.area_size, 0, 0])}, {_vec([0, 0, light.area_size])}, {n}, {n}"
                 " adaptive 0 jitter circular orient")
    return text + " }\n"


def scene_text(spec: SceneSpec, look: PovLook) -> str:
    """The scene file: settings, camera, sky, lights, floor, one texture per object; the
    objects' poses come from ``frame_NNNN.inc`` (frame_number of the animation)."""
    parts = [
        "#version 3.7;\n",
        f"global_settings {{ assumed_gamma 1.0 max_trace_level {MAX_TRACE_LEVEL} ambient_light rgb 1 }}\n",
        camera_statement(spec.camera),
        "sky_sphere { pigment { gradient y color_map { "
        f"[0 srgb {_vec(look.sky_horizon)}] [1 srgb {_vec(look.sky_zenith)}] }} }} }}\n",
        *(_light(light) for light in look.lights),
        _floor(look),
    ]
    for obj in spec.objects:
        finish = look.metal if obj.material == "metal" else look.rubber
        paint = [c * finish.body for c in look.paint(obj.color)]
        parts.append(f"#declare Paint{obj.object_id} = texture {{ pigment {{ srgb {_vec(paint)} }} {_finish(finish, look.ambient)} }}\n")
    parts.append('#include concat("frame_", str(frame_number, -4, 0), ".inc")\n')
    return "".join(parts)


def _shape(shape: str, half: float) -> str:
    """The primitive in its body frame (MuJoCo's geom axes, mapped to POV-Ray's): cylinder along body z."""
    if shape == "sphere":
        return f"sphere {{ <0, 0, 0>, {half:.7g}"
    if shape == "cube":
        return f"box {{ {_vec([-half] * 3)}, {_vec([half] * 3)}"
    return f"cylinder {{ {_vec(_pov([0, 0, -half]))}, {_vec(_pov([0, 0, half]))}, {half:.7g}"


def frame_text(spec: SceneSpec, sim: SimResult, frame: int) -> str:
    """Objects of one frame at their simulated poses: p_pov = S R S b + S t for a point b of the body."""
    by_id = {o.object_id: o for o in spec.objects}
    rows = []
    for k, oid in enumerate(sim.object_ids):
        obj = by_id[oid]
        rotation = WORLD_TO_POV @ quaternion_matrix(tuple(sim.quaternions[frame, k])) @ WORLD_TO_POV
        translation = _pov(sim.positions[frame, k])
        # POV-Ray's matrix takes the transposed 3x3 (row vectors) then the translation.
        values = list(rotation.T.reshape(-1)) + list(translation)
        rows.append(f"{_shape(obj.shape, obj.half_size)} texture {{ Paint{oid} }} matrix {_vec(values)} }}\n")
    return "".join(rows)


def _read_ppm(path: Path) -> np.ndarray:
    """(H, W, 3) uint8 from a binary PPM (P6, maxval 255) as POV-Ray writes it."""
    data = path.read_bytes()
    fields: list[bytes] = []
    position = 0
    while len(fields) < 4:
        while data[position : position + 1].isspace():
            position += 1
        if data[position : position + 1] == b"#":
            position = data.index(b"\n", position) + 1
            continue
        end = position
        while not data[end : end + 1].isspace():
            end += 1
        fields.append(data[position:end])
        position = end
    if fields[0] != b"P6" or fields[3] != b"255":
        raise ValueError(f"{path.name}: not an 8-bit binary PPM")
    width, height = int(fields[1]), int(fields[2])
    pixels = np.frombuffer(data, dtype=np.uint8, count=width * height * 3, offset=position + 1)
    return pixels.reshape(height, width, 3)


def _command(binary: str, spec: SceneSpec, frames: int, first: int, last: int) -> list[str]:
    width, height = spec.camera.width, spec.camera.height
    return [
        binary, "scene.pov", f"+W{width}", f"+H{height}", "+FP", "File_Gamma=sRGB", "Output_Alpha=off",
        f"+A{ANTIALIAS_THRESHOLD}", "+AM1", f"+R{ANTIALIAS_DEPTH}", "-J",
        "-D", "-V", "+WT1",
        # At least two animation frames: with one, POV-Ray leaves the frame number out of the file name.
        "+KFI0", f"+KFF{max(frames - 1, 1)}", f"+SF{first}", f"+EF{last}", "+Oframe_.ppm",
    ]


def render_scene_povray(spec: SceneSpec, sim: SimResult, look: PovLook, frames: int | None = None,
                        processes: int = 1) -> np.ndarray:
    """Ray-trace the first ``frames`` frames (default: the observed ones) in look ``look``.

    ``processes`` concurrent povray runs split the frames. Returns (F, H, W, 3)
    uint8 RGB. FileNotFoundError if povray is not installed; RuntimeError (with
    POV-Ray's last message) if it fails.
    """
    count = spec.observed_frames if frames is None else int(frames)
    if count < 1 or count > sim.positions.shape[0]:
        raise ValueError(f"frames: expected 1..{sim.positions.shape[0]}, got {count}")
    if processes < 1:
        raise ValueError(f"processes: expected >= 1, got {processes}")
    binary = povray_path()
    with tempfile.TemporaryDirectory(prefix="physmind-povray-") as tmp:
        work = Path(tmp)
        # POV-Ray's default file security reads only below its working directory: the floor image goes there.
        (work / CLEVRER_FLOOR_FILE).write_bytes(clevrer_floor_png())
        (work / "scene.pov").write_text(scene_text(spec, look))
        for frame in range(count):
            (work / f"frame_{frame:04d}.inc").write_text(frame_text(spec, sim, frame))
        bounds = np.linspace(0, count, min(processes, count) + 1).round().astype(int)
        runs = [
            subprocess.Popen(_command(binary, spec, count, int(a), int(b) - 1), cwd=work, stdin=subprocess.DEVNULL,
                             stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
            for a, b in zip(bounds[:-1], bounds[1:])
        ]
        failures = []
        for run, a, b in zip(runs, bounds[:-1], bounds[1:]):
            try:
                _, stderr = run.communicate(timeout=POVRAY_TIMEOUT_PER_FRAME * (b - a))
            except subprocess.TimeoutExpired:
                run.kill()
                _, stderr = run.communicate()
                failures.append(f"frames {a}-{b - 1}: timed out")
                continue
            if run.returncode != 0:
                last = [line for line in stderr.decode(errors="replace").splitlines() if line.strip()][-1:]
                failures.append(f"frames {a}-{b - 1}: exit code {run.returncode}: {last[0] if last else 'no message'}")
        if failures:
            raise RuntimeError(f"povray failed on scene {spec.scene_index}: {'; '.join(failures)}")
        outputs = sorted(work.glob("frame_*.ppm"), key=lambda p: int(p.stem.split("_")[-1]))
        if len(outputs) != count:
            raise RuntimeError(f"povray wrote {len(outputs)} of {count} frames of scene {spec.scene_index}")
        return np.stack([_read_ppm(path) for path in outputs])


def floor_point_in_view(camera: Camera) -> tuple[float, float, float]:
    """(3,) m: where the camera's optical axis meets the floor (z = 0)."""
    forward = np.asarray(camera.rotation, dtype=float)[:, 2]
    position = np.asarray(camera.position, dtype=float)
    if forward[2] >= 0:
        raise ValueError("camera: its optical axis does not meet the floor")
    return tuple(float(v) for v in position + forward * (-position[2] / forward[2]))


def scene_povray_look(spec: SceneSpec, seed: int, index: int) -> PovLook:
    """The POV-Ray look of scene ``index`` of dataset ``seed`` (its own stream; lights aim at the view)."""
    return sample_povray_look(np.random.default_rng(povray_look_seed_sequence(seed, index)), floor_point_in_view(spec.camera))
