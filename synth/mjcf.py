"""MJCF (MuJoCo XML) builder for a :class:`~synth.scene.SceneSpec`.

Contacts are listed explicitly as ``<pair>`` elements (dynamic collision is
off for every geom), so each pair carries its own friction and restitution:

* object-floor: sliding friction of the object, and for spheres condim 6 with
  torsional and rolling friction so they decelerate roughly constantly
  instead of rolling forever; critically damped (no bounce on the floor).
  Elliptic friction cones: with spheres' sliding friction well above their
  rolling resistance (mu >= 0.3 vs mu_roll / r <= 0.12) they roll without
  skidding and decelerate at (5/7) g mu_roll / r (tests/synth/test_physics.py).
* object-object: condim 3, friction the mean of the two sliding
  coefficients, and a linear spring-damper contact (MuJoCo's negative
  ``solref = -stiffness -damping``, impedance fixed at 0.99) with a contact
  half-period of CONTACT_HALF_PERIOD and the damping ratio that gives the
  pair's nominal coefficient of restitution e = sqrt(e_i e_j) (see
  :func:`dampratio_for_restitution`). Measured head-on with cubes at 2 m/s the
  realised e is within 0.04 of the nominal one (bench/synth_restitution.py);
  oblique and rolling impacts lose more, as MuJoCo computes them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from xml.sax.saxutils import quoteattr

import numpy as np

from synth.looks import CLEVRER_FLOOR_FILE, FloorLook, Look, LightLook, MaterialLook, clevrer_floor_png
from synth.scene import COLOR_RGB, ObjectSpec, SceneSpec, camera_fovy_deg

TIMESTEP = 0.002  # s; 20 physics steps per 25 fps frame
CONTACT_HALF_PERIOD = 0.02  # s, duration of an object-object impact (10 physics steps)
# Convex collisions by libccd, not MuJoCo's native CCD (MuJoCo's default): with the native one a
# cylinder striking a cube at some yaws threw both apart with up to 10x the kinetic energy they brought
# (one in seven isolated cube-cylinder collisions of synth-2 datasets, bench/synth_energy.py; none with
# libccd, and no other shape pair). tests/synth/test_physics.py::test_a_cylinder_striking_a_cube_gains_no_energy.
NATIVE_CCD = False
FLOOR_FRICTION = 0.01  # low; each pair sets its own friction anyway


def dampratio_for_restitution(restitution: float) -> float:
    """Damping ratio zeta of a linear spring-damper whose bounce has coefficient e.

    For an underdamped oscillator the velocity ratio over one half period is
    e = exp(-zeta pi / sqrt(1 - zeta^2)), hence
    zeta = -ln e / sqrt(pi^2 + ln^2 e). MuJoCo's soft contact is such a
    spring-damper in its reference acceleration (solref = timeconst, dampratio).
    """
    if not 0.0 < restitution < 1.0:
        raise ValueError(f"restitution: expected a value in (0, 1), got {restitution!r}")
    log_e = math.log(restitution)
    return -log_e / math.sqrt(math.pi**2 + log_e**2)


def contact_stiffness_damping(restitution: float) -> tuple[float, float]:
    """Mass-normalised stiffness (1/s^2) and damping (1/s) of an object-object contact.

    omega = pi / CONTACT_HALF_PERIOD; stiffness = omega^2, damping = 2 zeta omega.
    """
    omega = math.pi / CONTACT_HALF_PERIOD
    return omega**2, 2.0 * dampratio_for_restitution(restitution) * omega


def pair_restitution(a: ObjectSpec, b: ObjectSpec) -> float:
    """Coefficient of restitution of the pair (geometric mean of the two)."""
    return math.sqrt(a.restitution * b.restitution)


@dataclass(frozen=True)
class BuiltModel:
    """The XML text plus the object ids in body order (body k is ``object_ids[k]``)
    and the files the XML names (``assets``: file name -> bytes, for MuJoCo)."""

    xml: str
    object_ids: tuple[int, ...]
    assets: dict[str, bytes] | None = None


def _fmt(values) -> str:
    return " ".join(f"{float(v):.9g}" for v in values)


def _geom(obj: ObjectSpec) -> str:
    half = obj.half_size
    if obj.shape == "sphere":
        kind, size = "sphere", [half]
    elif obj.shape == "cube":
        kind, size = "box", [half, half, half]
    else:
        kind, size = "cylinder", [half, half]
    return (
        f'<geom name="geom{obj.object_id}" type="{kind}" size="{_fmt(size)}" mass="{obj.mass:.9g}" '
        f'material="{obj.color}_{obj.material}" contype="0" conaffinity="0"/>'
    )


def _quat_wxyz_from_yaw(yaw: float) -> tuple[float, float, float, float]:
    return (math.cos(yaw / 2.0), 0.0, 0.0, math.sin(yaw / 2.0))


def _materials(materials: MaterialLook | None = None) -> str:
    """The <material> elements of every colour x material; None: the default look's."""
    if materials is not None:
        return _look_materials(materials)
    rows = []
    for color, (r, g, b) in COLOR_RGB.items():
        rgba = _fmt([r / 255.0, g / 255.0, b / 255.0, 1.0])
        # Metal: darker body colour with strong highlights (a rim light from behind
        # lights its top faces); rubber: full colour, matte.
        dark = _fmt([0.62 * r / 255.0, 0.62 * g / 255.0, 0.62 * b / 255.0, 1.0])
        rows.append(f'<material name="{color}_metal" rgba="{dark}" specular="1" shininess="0.7"/>')
        rows.append(f'<material name="{color}_rubber" rgba="{rgba}" specular="0.05" shininess="0.05"/>')
    return "\n    ".join(rows)


def _look_materials(materials: MaterialLook) -> str:
    rows = []
    for color in COLOR_RGB:
        paint = materials.paint(color)
        body = _fmt([materials.metal_body * c for c in paint] + [1.0])
        rows.append(
            f'<material name="{color}_metal" rgba="{body}" specular="{materials.metal_specular:.9g}" '
            f'shininess="{materials.metal_shininess:.9g}"/>'
        )
        rows.append(
            f'<material name="{color}_rubber" rgba="{_fmt([*paint, 1.0])}" specular="{materials.rubber_specular:.9g}" '
            f'shininess="{materials.rubber_shininess:.9g}"/>'
        )
    return "\n    ".join(rows)


# The default look's floor, lights and head light (synth-1; the fixtures were rendered with these).
DEFAULT_FLOOR = '<material name="floor" rgba="0.52 0.52 0.53 1" specular="0.08" shininess="0.1"/>'
DEFAULT_LIGHTS = """<light name="key" directional="true" pos="-3 -4 8" dir="0.35 0.45 -1" diffuse="0.55 0.55 0.55" specular="0.6 0.6 0.6" castshadow="true"/>
    <light name="fill" directional="true" pos="4 -2 6" dir="-0.4 0.3 -1" diffuse="0.18 0.18 0.18" specular="0.25 0.25 0.25" castshadow="false"/>
    <light name="rim" directional="true" pos="0 6 6" dir="0 -0.75 -0.66" diffuse="0.06 0.06 0.06" specular="0.4 0.4 0.4" castshadow="false"/>"""
DEFAULT_HEADLIGHT_AMBIENT = 0.32
DEFAULT_SHADOW_SIZE = 2048
# Shadow map resolution (texels) per shadow style; "none" casts no shadow.
SHADOW_SIZE = {"hard": 4096, "soft": 1024, "none": DEFAULT_SHADOW_SIZE}
SOFT_KEY_LIGHTS = 4  # lights making one soft key light
SOFT_KEY_SPREAD_DEG = 3.0  # angular radius of that ring of lights
# Shadow frustum of directional lights, in model extents (MuJoCo's map
# shadowclip, default 1): wide enough that the far floor of the looks' cameras
# is inside it (outside, MuJoCo's shadow lookup speckles the floor).
LOOK_SHADOW_CLIP = 4.0
SPECKLE_SHARE = 0.35  # share of floor texels in the second colour


def _floor_asset(floor: FloorLook) -> str:
    """Floor texture and material; texuniform repeats the texture every ``floor.tile`` m."""
    repeat = _fmt([1.0 / floor.tile, 1.0 / floor.tile])
    material = f'specular="{floor.specular:.9g}" shininess="0.1"'
    if floor.texture == "flat":
        return f'<material name="floor" rgba="{_fmt([*floor.rgb, 1.0])}" {material}/>'
    if floor.texture == "checker":
        texture = f'<texture name="floor_tex" type="2d" builtin="checker" rgb1="{_fmt(floor.rgb)}" rgb2="{_fmt(floor.rgb2)}" width="64" height="64"/>'
    elif floor.texture == "speckle":
        texture = (
            f'<texture name="floor_tex" type="2d" builtin="flat" rgb1="{_fmt(floor.rgb)}" mark="random" random="{SPECKLE_SHARE}" '
            f'markrgb="{_fmt(floor.rgb2)}" width="96" height="96"/>'
        )
    else:  # the CLEVRER floor image, stretched over one tile
        texture = f'<texture name="floor_tex" type="2d" file="{CLEVRER_FLOOR_FILE}"/>'
    return f'{texture}\n    <material name="floor" texture="floor_tex" texrepeat="{repeat}" texuniform="true" rgba="1 1 1 1" {material}/>'


def _light_elements(light: LightLook) -> str:
    """Key light from the look, a fill light opposite it and a faint rim light.

    Soft shadows: MuJoCo's directional lights cast hard-edged shadows, so a
    soft key light is SOFT_KEY_SPREAD_DEG-wide ring of SOFT_KEY_LIGHTS lights
    sharing the intensity; their overlapping shadows grade the penumbra.
    """
    diffuse = np.array([light.intensity * t for t in light.tint])
    if light.shadows == "soft":
        keys = [
            (light.azimuth_deg + SOFT_KEY_SPREAD_DEG * math.cos(a) / max(math.cos(math.radians(light.elevation_deg)), 0.2),
             light.elevation_deg + SOFT_KEY_SPREAD_DEG * math.sin(a))
            for a in np.linspace(0.0, 2.0 * math.pi, SOFT_KEY_LIGHTS, endpoint=False)
        ]
    else:
        keys = [(light.azimuth_deg, light.elevation_deg)]
    shadow = "true" if light.shadows != "none" else "false"
    rows = []
    for k, (azimuth, elevation) in enumerate(keys):
        direction = LightLook(azimuth, min(elevation, 89.0), light.intensity, light.tint, light.ambient, light.shadows).direction
        rows.append(
            f'<light name="key{k}" directional="true" pos="{_fmt([-8.0 * v for v in direction])}" dir="{_fmt(direction)}" '
            f'diffuse="{_fmt(diffuse / len(keys))}" specular="{_fmt([0.6 / len(keys)] * 3)}" castshadow="{shadow}"/>'
        )
    fill_az = math.radians(light.azimuth_deg + 180.0)
    fill_dir = [-0.6 * math.cos(fill_az), -0.6 * math.sin(fill_az), -1.0]
    rows.append(
        f'<light name="fill" directional="true" pos="{_fmt([-6.0 * v for v in fill_dir])}" dir="{_fmt(fill_dir)}" '
        f'diffuse="{_fmt(0.33 * diffuse)}" specular="0.25 0.25 0.25" castshadow="false"/>'
    )
    rows.append('<light name="rim" directional="true" pos="0 6 6" dir="0 -0.75 -0.66" diffuse="0.06 0.06 0.06" specular="0.4 0.4 0.4" castshadow="false"/>')
    return "\n    ".join(rows)


@dataclass(frozen=True)
class _LookXml:
    floor: str  # <texture>/<material> elements of the floor
    lights: str  # <light> elements
    ambient: float  # head-light ambient, 0..1
    shadow_size: int  # shadow map texels
    map_extra: str  # extra <map> attributes
    assets: dict[str, bytes]  # files the XML names


def _look_xml(look: Look) -> _LookXml:
    """The MJCF pieces of a look; the default look gives synth-1's exact text."""
    if look.floor is None or look.light is None:
        return _LookXml(DEFAULT_FLOOR, DEFAULT_LIGHTS, DEFAULT_HEADLIGHT_AMBIENT, DEFAULT_SHADOW_SIZE, "", {})
    assets = {CLEVRER_FLOOR_FILE: clevrer_floor_png()} if look.floor.texture == "clevrer" else {}
    return _LookXml(
        _floor_asset(look.floor),
        _light_elements(look.light),
        look.light.ambient,
        SHADOW_SIZE[look.light.shadows],
        f' shadowclip="{LOOK_SHADOW_CLIP:.9g}"',
        assets,
    )


def build_mjcf(spec: SceneSpec, removed: int | None = None) -> BuiltModel:
    """MJCF text of the scene; ``removed`` drops that object from the start (counterfactual)."""
    objects = [o for o in spec.objects if o.object_id != removed]
    if removed is not None and len(objects) == len(spec.objects):
        raise ValueError(f"removed: no object with id {removed!r} in scene {spec.scene_index}")
    cam = spec.camera
    look = _look_xml(spec.look)
    # MuJoCo cameras look along their -z axis with +y up: x = OpenCV x, y = -OpenCV y.
    rot = cam.rotation
    x_axis = [rot[0][0], rot[1][0], rot[2][0]]
    y_axis = [-rot[0][1], -rot[1][1], -rot[2][1]]
    bodies = []
    for obj in objects:
        bodies.append(
            f'<body name="obj{obj.object_id}" pos="{_fmt(obj.position)}" quat="{_fmt(_quat_wxyz_from_yaw(obj.yaw))}">'
            f'<freejoint name="joint{obj.object_id}"/>{_geom(obj)}</body>'
        )
    pairs = []
    for obj in objects:
        if obj.shape == "sphere":
            friction = [obj.friction, obj.friction, obj.torsional_friction, obj.rolling_friction, obj.rolling_friction]
            condim = 6
        else:
            friction = [obj.friction, obj.friction, 0.0, 0.0, 0.0]
            condim = 3
        pairs.append(
            f'<pair geom1="floor" geom2="geom{obj.object_id}" condim="{condim}" friction="{_fmt(friction)}" '
            f'solref="0.01 1"/>'
        )
    for i, a in enumerate(objects):
        for b in objects[i + 1 :]:
            mu = 0.5 * (a.friction + b.friction)
            stiffness, damping = contact_stiffness_damping(pair_restitution(a, b))
            pairs.append(
                f'<pair geom1="geom{a.object_id}" geom2="geom{b.object_id}" condim="3" '
                f'friction="{_fmt([mu, mu, 0.0, 0.0, 0.0])}" solref="{_fmt([-stiffness, -damping])}" '
                f'solimp="0.99 0.99 0.001"/>'
            )
    xml = f"""<mujoco model={quoteattr(f"scene_{spec.scene_index:05d}")}>
  <compiler angle="radian"/>
  <option timestep="{TIMESTEP}" integrator="implicitfast" cone="elliptic" gravity="0 0 -9.81"><flag nativeccd="{'enable' if NATIVE_CCD else 'disable'}"/></option>
  <visual>
    <global offwidth="{cam.width}" offheight="{cam.height}"/>
    <quality shadowsize="{look.shadow_size}" offsamples="4"/>
    <headlight ambient="{_fmt([look.ambient] * 3)}" diffuse="0.25 0.25 0.25" specular="0.1 0.1 0.1"/>
    <map znear="0.05" zfar="60"{look.map_extra}/>
  </visual>
  <asset>
    {look.floor}
    {_materials(spec.look.materials)}
  </asset>
  <worldbody>
    {look.lights}
    <geom name="floor" type="plane" size="0 0 0.05" material="floor" friction="{FLOOR_FRICTION} 0 0" contype="0" conaffinity="0"/>
    <camera name="main" pos="{_fmt(cam.position)}" xyaxes="{_fmt(x_axis + y_axis)}" fovy="{camera_fovy_deg(cam):.9g}"/>
    {chr(10).join('    ' + b for b in bodies).strip()}
  </worldbody>
  <contact>
    {chr(10).join('    ' + p for p in pairs).strip()}
  </contact>
</mujoco>
"""
    return BuiltModel(xml=xml, object_ids=tuple(o.object_id for o in objects), assets=look.assets)
