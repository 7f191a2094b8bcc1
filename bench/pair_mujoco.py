"""Two-object impacts in MuJoCo with the scene generator's contact model (synth.mjcf).

Ground truth for the friction-between-objects law (tests/world/test_contact_friction_mujoco.py, bench/bench_contact_friction.py):
one object launched at a resting one, off-centre, run through ``synth.simulate``
(the generator's own MJCF: pair friction the mean of the two sliding
coefficients, spring-damper restitution, spheres launched rolling).
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

from synth.mjcf import pair_restitution
from synth.scene import GRAVITY, OBJECT_HALF_SIZE, ObjectSpec, SceneSpec, camera_look_at, deceleration
from synth.simulate import SimResult, load_model, simulate
from world.types import Body, BodyState, Shape, World

DENSITY = 1100.0  # kg/m^3, rubber


def _volume(shape: str) -> float:
    h = OBJECT_HALF_SIZE
    return {"sphere": 4.0 / 3.0 * math.pi * h**3, "cube": 8.0 * h**3, "cylinder": 2.0 * math.pi * h**3}[shape]


def pair_spec(shapes: tuple[str, str], speed: float, offset: float, frictions: tuple[float, float],
              restitution: float = 0.7, mass_ratio: float = 1.0, rolling_friction: float = 0.015,
              yaws: tuple[float, float] = (0.0, 0.0)) -> SceneSpec:
    """Object 0 at (-1, 0) launched along +x at ``speed`` m/s into object 1 resting at (0, offset) m.

    frictions: sliding (floor) coefficients; a sphere's is its skid friction.
    mass_ratio: object 1's density over object 0's. yaws: rad, of object 0 and 1
    (a cube turned by pi/4 leads with a corner).
    """
    camera = camera_look_at(np.array([0.0, -6.0, 4.0]), np.array([0.0, 0.0, 0.0]), 36.0)
    objects = []
    for k, (shape, position, velocity) in enumerate(zip(shapes, ((-1.0, 0.0), (0.0, offset)), ((speed, 0.0), (0.0, 0.0)))):
        objects.append(ObjectSpec(
            k, "red", "rubber", shape, (position[0], position[1], OBJECT_HALF_SIZE), (velocity[0], velocity[1], 0.0), yaws[k],
            mass=DENSITY * (mass_ratio if k else 1.0) * _volume(shape), friction=frictions[k],
            rolling_friction=rolling_friction if shape == "sphere" else 0.0,
            torsional_friction=0.01 if shape == "sphere" else 0.0, restitution=restitution,
            role="moving" if k == 0 else "rest"))
    return SceneSpec(0, camera, tuple(objects))


def run_pair(spec: SceneSpec, seconds: float) -> SimResult:
    return simulate(spec, horizon_frames=int(round(seconds * spec.fps)) + 1)


def lone_spec(shape: str, velocity: tuple[float, float], friction: float) -> SceneSpec:
    """One cube or cylinder at the origin (yaw 0) on the generator's floor, launched at ``velocity`` m/s."""
    camera = camera_look_at(np.array([0.0, -6.0, 4.0]), np.array([0.0, 0.0, 0.0]), 36.0)
    obj = ObjectSpec(0, "red", "rubber", shape, (0.0, 0.0, OBJECT_HALF_SIZE), (velocity[0], velocity[1], 0.0), 0.0,
                     mass=DENSITY * _volume(shape), friction=friction, rolling_friction=0.0, torsional_friction=0.0,
                     restitution=0.7, role="moving")
    return SceneSpec(0, camera, (obj,))


def run_spinning(spec: SceneSpec, yaw_rate: float, seconds: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The lone object of ``spec`` launched with its velocity and ``yaw_rate`` rad/s about z, in MuJoCo
    with the generator's model (the generator itself launches no spin).

    Returns per frame (0 .. seconds * fps): planar positions (T, 2) m, yaw (T,) rad (unwrapped),
    yaw rates (T,) rad/s.
    """
    model, _ = load_model(spec)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    data.qvel[0:3] = spec.objects[0].velocity
    data.qvel[3:6] = (0.0, 0.0, yaw_rate)  # body frame = world frame for an upright body at yaw 0
    mujoco.mj_forward(model, data)
    frames = int(round(seconds * spec.fps)) + 1
    steps_per_frame = int(round(1.0 / (spec.fps * model.opt.timestep)))
    positions, yaws, rates = np.zeros((frames, 2)), np.zeros(frames), np.zeros(frames)
    for frame in range(frames):
        positions[frame] = data.xpos[1][:2]
        w, x, y, z = data.xquat[1]
        yaws[frame] = math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
        rates[frame] = (data.xmat[1].reshape(3, 3) @ data.qvel[3:6])[2]
        for _ in range(steps_per_frame):
            mujoco.mj_step(model, data)
    return positions, np.unwrap(yaws), rates


def engine_world(spec: SceneSpec, observed_frames: int, contact_friction: bool = True,
                 slip_removal: float = 1.0, rolling_spheres: bool = True) -> World:
    """The same scene for our engine: the generator's parameters, the pair's nominal restitution;
    spheres roll (skid friction = sliding coefficient), or slide at their rolling deceleration
    (``rolling_spheres=False``, the sliding model); contact_friction = each object's sliding
    coefficient (so the pair's mean is the generator's pair friction), or none."""
    bodies = []
    for obj in spec.objects:
        sphere = obj.shape == "sphere"
        shape = Shape("sphere", radius=OBJECT_HALF_SIZE) if sphere else (
            Shape("cube", half_extent=OBJECT_HALF_SIZE) if obj.shape == "cube" else Shape("cylinder", radius=OBJECT_HALF_SIZE, half_height=OBJECT_HALF_SIZE))
        rolling = deceleration(obj.shape, obj.friction, obj.rolling_friction) / GRAVITY if sphere else None
        slides = sphere and not rolling_spheres
        bodies.append(Body(obj.object_id, shape, BodyState(obj.position, obj.velocity, obj.yaw), mass=obj.mass,
                           friction=rolling if slides else obj.friction, restitution=obj.restitution,
                           rolling_friction=None if slides else rolling,
                           contact_friction=obj.friction if contact_friction else None))
    e = pair_restitution(*spec.objects)
    return World(tuple(bodies), fps=spec.fps, observed_frames=observed_frames, pair_restitution=((0, 1, e),),
                 contact_slip_removal=slip_removal)


def direction_error_deg(ours: np.ndarray, truth: np.ndarray) -> float:
    """Signed angle (degrees) from our planar velocity (2,) to MuJoCo's (2,)."""
    return float(np.degrees(np.arctan2(ours[0] * truth[1] - ours[1] * truth[0], ours @ truth)))
