"""Scene specification and its seeded sampler (no physics, no rendering).

A :class:`SceneSpec` is everything needed to build the MuJoCo model of one
CLEVRER-style scene: the camera, the objects with their attributes, physical
parameters and initial states. Sampling is a pure function of a
``numpy.random.Generator``; the same generator state gives the same spec.

Units: metres, seconds, kilograms, radians. World frame: z up, floor z = 0.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from synth.looks import DEFAULT_LOOK, CameraLook, Look
from world.camera import backproject_to_height, centre_in_view  # the one owner of the pinhole model
from world.types import CLEVR_PALETTE_RGB, COLORS, MATERIALS, SHAPE_KINDS, Camera

# --- fixed scene constants -------------------------------------------------

IMAGE_WIDTH = 480  # pixels
IMAGE_HEIGHT = 320  # pixels
FPS = 25.0  # frames per second, as CLEVRER
OBSERVED_FRAMES = 128  # frames written to the video, as CLEVRER
FUTURE_FRAMES = 52  # >= 2 s simulated after the video for predictive ground truth
OBJECT_HALF_SIZE = 0.2  # m; one size as CLEVRER: sphere radius, cube half side, cylinder radius and half height

COLOR_RGB = CLEVR_PALETTE_RGB  # the paint of each colour name (world.types owns the palette)

# --- documented physical ranges (each drawn uniformly per object) ----------
# Densities, kg/m^3: natural/synthetic rubber 900-1300; the "metal" is a light
# alloy (aluminium 2700, titanium 4500), so metal is 2-5x heavier than rubber.
DENSITY_RANGE = {"rubber": (900.0, 1300.0), "metal": (2600.0, 4500.0)}
# Sliding (Coulomb) friction of cubes and cylinders with the floor. Chosen
# low (a polished floor, as CLEVRER's objects glide for seconds); metal
# slides more easily than rubber.
SLIDING_FRICTION_RANGE = {"rubber": (0.06, 0.11), "metal": (0.045, 0.09)}
# Spheres roll: their sliding friction only has to keep them from skidding
# (hard rubber/metal on a hard floor, 0.3-0.5); rolling friction below sets
# their deceleration.
SPHERE_SLIDING_FRICTION_RANGE = {"rubber": (0.35, 0.5), "metal": (0.3, 0.45)}
# Rolling friction length (m) of spheres (MuJoCo condim 6): a rolling sphere of
# radius r decelerates at about (5/7) g mu_roll / r, i.e. 0.4-0.8 m/s^2 here.
ROLLING_FRICTION_RANGE = (0.011, 0.023)
TORSIONAL_FRICTION = 0.01  # m, spin friction length (condim 6)
# Coefficient of restitution of object-object impacts: rubber bounces less.
RESTITUTION_RANGE = {"rubber": (0.55, 0.75), "metal": (0.7, 0.9)}

# --- camera: about 45 degrees down, randomised slightly per scene -----------
CAMERA_PITCH_DEG = (42.0, 48.0)  # angle of the optical axis below the horizon
CAMERA_YAW_DEG = (-4.0, 4.0)  # azimuth offset about +z
CAMERA_DISTANCE = (5.2, 5.8)  # m, from the camera to its look-at point
CAMERA_FOVY_DEG = 36.0  # vertical field of view
CAMERA_TARGET = (0.0, 0.4, 0.0)  # look-at point on the floor, m

# Points around a waiting object (m, relative to its centre) that must all be
# out of view: its footprint, top and shadow.
HIDDEN_OFFSETS = np.array(
    [[dx, dy, dz] for dx in (-0.5, 0.0, 0.5) for dy in (-0.5, 0.0, 0.5) for dz in (-OBJECT_HALF_SIZE, OBJECT_HALF_SIZE)]
)

MIN_SPEED = 0.6  # m/s, slowest launch of a moving object
MAX_SPEED = 4.0  # m/s, fastest launch
GRAVITY = 9.81


@dataclass(frozen=True)
class ObjectSpec:
    """One object of a scene.

    position: (3,) m, initial centre (z = OBJECT_HALF_SIZE, resting on the floor).
    velocity: (3,) m/s initial linear velocity (z = 0).
    yaw: rad about +z. mass: kg. friction: sliding Coulomb coefficient.
    rolling_friction, torsional_friction: m (MuJoCo condim 6 lengths).
    restitution: nominal coefficient of restitution in (0, 1).
    role: how the sampler placed it: "rest", "moving" or "entering".
    launch_frame: frame at which ``velocity`` is imparted (0: moving from the
    start). An entering object waits at rest out of view until then, as
    CLEVRER's objects that enter the scene part-way through the video.
    """

    object_id: int
    color: str
    material: str
    shape: str
    position: tuple[float, float, float]
    velocity: tuple[float, float, float]
    yaw: float
    mass: float
    friction: float
    rolling_friction: float
    torsional_friction: float
    restitution: float
    role: str
    launch_frame: int = 0

    @property
    def half_size(self) -> float:
        return OBJECT_HALF_SIZE


@dataclass(frozen=True)
class SceneSpec:
    """A full scene: camera + objects + look; ``scene_index`` names its files."""

    scene_index: int
    camera: Camera
    objects: tuple[ObjectSpec, ...]
    fps: float = FPS
    observed_frames: int = OBSERVED_FRAMES
    future_frames: int = FUTURE_FRAMES
    look: Look = DEFAULT_LOOK

    @property
    def horizon_frames(self) -> int:
        return self.observed_frames + self.future_frames


# --- camera geometry --------------------------------------------------------


def camera_look_at(position: np.ndarray, target: np.ndarray, fovy_deg: float) -> Camera:
    """Pinhole camera at ``position`` (3,) m looking at ``target`` (3,) m.

    Returns a world.types.Camera in the OpenCV convention (x right, y down,
    z forward; rotation maps camera-frame vectors to the world frame). The
    principal point follows OpenCV's pixel-centre convention: the optical axis
    passes between the two middle pixels, so cx = (W - 1) / 2.
    """
    forward = target - position
    forward = forward / np.linalg.norm(forward)
    right = np.cross(forward, np.array([0.0, 0.0, 1.0]))
    right = right / np.linalg.norm(right)
    down = np.cross(forward, right)
    rotation = np.stack([right, down, forward], axis=1)
    focal = (IMAGE_HEIGHT / 2.0) / math.tan(math.radians(fovy_deg) / 2.0)
    return Camera(
        width=IMAGE_WIDTH,
        height=IMAGE_HEIGHT,
        fx=focal,
        fy=focal,
        cx=(IMAGE_WIDTH - 1) / 2.0,
        cy=(IMAGE_HEIGHT - 1) / 2.0,
        position=tuple(float(v) for v in position),
        rotation=tuple(tuple(float(v) for v in row) for row in rotation),
    )


def camera_fovy_deg(camera: Camera) -> float:
    """Vertical field of view (degrees) of a camera, as MuJoCo's ``fovy``."""
    return math.degrees(2.0 * math.atan((camera.height / 2.0) / camera.fy))


def inside_view(camera: Camera, points: np.ndarray) -> np.ndarray:
    """(M,) bool: the point (object centre) projects inside the image, in front of the camera."""
    return centre_in_view(camera, points)


def camera_from_pose(distance: float, tilt_deg: float, yaw_deg: float, fovy_deg: float, target: np.ndarray) -> Camera:
    """Camera ``distance`` m from the floor point ``target`` (3,), ``tilt_deg`` below
    the horizon, on the -y side turned by ``yaw_deg`` about +z, looking at ``target``."""
    pitch, yaw = math.radians(tilt_deg), math.radians(yaw_deg)
    offset = distance * np.array([math.sin(yaw) * math.cos(pitch), -math.cos(yaw) * math.cos(pitch), math.sin(pitch)])
    return camera_look_at(np.asarray(target, dtype=float) + offset, np.asarray(target, dtype=float), fovy_deg)


def sample_camera(rng: np.random.Generator) -> Camera:
    """A CLEVRER-like camera (the default look): about 45 degrees down, a few degrees and centimetres of jitter."""
    pitch = rng.uniform(*CAMERA_PITCH_DEG)
    yaw = rng.uniform(*CAMERA_YAW_DEG)
    distance = rng.uniform(*CAMERA_DISTANCE)
    target = np.array(CAMERA_TARGET) + np.array([rng.uniform(-0.15, 0.15), rng.uniform(-0.15, 0.15), 0.0])
    return camera_from_pose(distance, pitch, yaw, CAMERA_FOVY_DEG, target)


def look_camera(camera: CameraLook) -> Camera:
    """The camera a (non-default) look fixes."""
    return camera_from_pose(camera.distance, camera.tilt_deg, camera.yaw_deg, camera.fovy_deg, np.array(camera.target))


def camera_geometry(camera: Camera) -> dict[str, float]:
    """Height (m), tilt below the horizon (deg), distance along the optical axis
    to the floor (m), vertical fov (deg) and the pixel height of a 0.4 m object
    on the floor at the image centre: what a look's camera amounts to."""
    forward = np.asarray(camera.rotation)[:, 2]
    height = float(camera.position[2])
    tilt = math.degrees(math.asin(-forward[2]))
    distance = height / max(float(-forward[2]), 1e-9)
    return {
        "height": height,
        "tilt_deg": tilt,
        "distance": distance,
        "fovy_deg": camera_fovy_deg(camera),
        "object_pixels": 2.0 * OBJECT_HALF_SIZE * camera.fy / distance,
    }


# --- object sampling ---------------------------------------------------------


def _shape_volume(shape: str, half: float) -> float:
    if shape == "sphere":
        return 4.0 / 3.0 * math.pi * half**3
    if shape == "cube":
        return (2.0 * half) ** 3
    return math.pi * half**2 * (2.0 * half)


def _physical_parameters(rng: np.random.Generator, shape: str, material: str) -> dict[str, float]:
    density = rng.uniform(*DENSITY_RANGE[material])
    return {
        "mass": density * _shape_volume(shape, OBJECT_HALF_SIZE),
        "friction": rng.uniform(*(SPHERE_SLIDING_FRICTION_RANGE if shape == "sphere" else SLIDING_FRICTION_RANGE)[material]),
        "rolling_friction": rng.uniform(*ROLLING_FRICTION_RANGE) if shape == "sphere" else 0.0,
        "torsional_friction": TORSIONAL_FRICTION if shape == "sphere" else 0.0,
        "restitution": rng.uniform(*RESTITUTION_RANGE[material]),
    }


def deceleration(shape: str, friction: float, rolling_friction: float) -> float:
    """Nominal deceleration (m/s^2) of a freely moving object, for aiming launches.

    Boxes and cylinders slide (mu g); spheres are launched rolling and
    decelerate by rolling resistance, about (5/7) g mu_roll / r.
    """
    if shape == "sphere":
        return 5.0 / 7.0 * GRAVITY * rolling_friction / OBJECT_HALF_SIZE
    return friction * GRAVITY


def _sample_inside_points(rng: np.random.Generator, camera: Camera, count: int) -> np.ndarray:
    """(count, 3) floor points whose objects are well inside the image."""
    u = rng.uniform(0.14 * camera.width, 0.86 * camera.width, size=count)
    v = rng.uniform(0.22 * camera.height, 0.88 * camera.height, size=count)
    return backproject_to_height(camera, np.stack([u, v], axis=1), OBJECT_HALF_SIZE)


def _sample_edge_point(rng: np.random.Generator, camera: Camera) -> np.ndarray:
    """(3,) floor point whose object is partly out of view: its centre lies
    within 5 % of the image's left, right or bottom edge (still inside)."""
    side = int(rng.integers(3))
    if side == 2:
        u, v = rng.uniform(0.2, 0.8) * camera.width, rng.uniform(0.95, 0.995) * camera.height
    else:
        u = (rng.uniform(0.005, 0.05) if side == 0 else rng.uniform(0.95, 0.995)) * camera.width
        v = rng.uniform(0.35, 0.9) * camera.height
    return backproject_to_height(camera, np.array([[u, v]]), OBJECT_HALF_SIZE)[0]


def _launch_speed(rng: np.random.Generator, distance: float, decel: float) -> float:
    """Speed (m/s) that carries an object over ``distance`` m and leaves it 0.5-1.2 m/s there."""
    arrival = rng.uniform(0.5, 1.2)
    return float(np.clip(math.sqrt(arrival**2 + 2.0 * decel * max(distance, 0.0)), MIN_SPEED, MAX_SPEED))


def _distinct_attributes(rng: np.random.Generator, count: int) -> list[tuple[str, str, str]]:
    """``count`` distinct (color, material, shape) triples; colours may repeat, as in CLEVRER."""
    chosen: list[tuple[str, str, str]] = []
    while len(chosen) < count:
        triple = (str(rng.choice(COLORS)), str(rng.choice(MATERIALS)), str(rng.choice(SHAPE_KINDS)))
        used_colors = [c for c, _, _ in chosen]
        if triple in chosen or (triple[0] in used_colors and rng.uniform() < 0.3):
            continue
        chosen.append(triple)
    return chosen


def sample_scene(rng: np.random.Generator, scene_index: int, look: Look = DEFAULT_LOOK) -> SceneSpec:
    """Draw one scene: camera, objects (3-6 for the default look, else the
    look's count); some rest, some move in view, some enter from outside.

    Moving objects are aimed (with a few degrees of noise) at another object
    so that collision chains are likely; the caller re-draws scenes whose
    simulated collisions are too few (see synth.generate). The default look
    draws its camera here (synth-1's stream, so its scenes are unchanged);
    other looks fix the camera and may place objects partly out of view.
    """
    camera = sample_camera(rng) if look.camera is None else look_camera(look.camera)
    count = int(rng.integers(look.object_count[0], look.object_count[1] + 1))
    attributes = _distinct_attributes(rng, count)
    n_enter = int(rng.choice([0, 1, 1, 2, 2]))
    n_enter = min(n_enter, count - 2)
    n_moving = int(rng.integers(1, max(2, count - n_enter - 1) + 1))
    n_moving = min(n_moving, count - n_enter - 1)
    roles = ["entering"] * n_enter + ["moving"] * n_moving + ["rest"] * (count - n_enter - n_moving)
    roles = [str(r) for r in rng.permutation(roles)]

    # Positions of in-view objects: rejection-sample a spread-out layout.
    in_view = [i for i, r in enumerate(roles) if r != "entering"]
    positions = np.zeros((count, 3))
    placed: list[np.ndarray] = []
    for i in in_view:
        at_edge = look.edge_share > 0 and rng.uniform() < look.edge_share
        for _ in range(200):
            candidate = _sample_edge_point(rng, camera) if at_edge else _sample_inside_points(rng, camera, 1)[0]
            if all(np.linalg.norm(candidate[:2] - p[:2]) > 0.75 for p in placed):
                break
        placed.append(candidate)
        positions[i] = candidate

    params = [_physical_parameters(rng, shape, material) for (_, material, shape) in attributes]
    velocities = np.zeros((count, 3))
    yaws = rng.uniform(-math.pi, math.pi, size=count)
    targets_pool = [i for i in in_view]

    for i, role in enumerate(roles):
        shape = attributes[i][2]
        decel = deceleration(shape, params[i]["friction"], params[i]["rolling_friction"])
        if role == "moving":
            others = [j for j in targets_pool if j != i]
            target = positions[int(rng.choice(others))][:2]
            direction = target - positions[i][:2]
            distance = float(np.linalg.norm(direction))
            angle = math.atan2(direction[1], direction[0]) + math.radians(rng.normal(0.0, 4.0))
            speed = _launch_speed(rng, distance, decel)
            velocities[i, :2] = speed * np.array([math.cos(angle), math.sin(angle)])
        elif role == "entering":
            # Prefer objects at rest: they are still there when a late object arrives.
            resting = [j for j in targets_pool if roles[j] == "rest"]
            pool = resting if resting and rng.uniform() < 0.7 else targets_pool
            target = positions[int(rng.choice(pool))][:2] if pool else np.zeros(2)
            for _ in range(100):
                heading = rng.uniform(-math.pi, math.pi)
                unit = np.array([math.cos(heading), math.sin(heading)])
                # Walk back from the target until no part of the object (nor
                # its shadow) can be seen while it waits, then a margin.
                back = 0.4
                while back < 8.0:
                    start = np.array([*(target - unit * back), OBJECT_HALF_SIZE])
                    if not inside_view(camera, start[None] + HIDDEN_OFFSETS).any():
                        break
                    back += 0.1
                back += rng.uniform(0.1, 0.5)
                start = np.array([*(target - unit * back), OBJECT_HALF_SIZE])
                clear = all(np.linalg.norm(start[:2] - positions[j][:2]) > 0.75 for j in range(count) if j != i and (roles[j] != "entering" or j < i))
                speed = _launch_speed(rng, back, decel)
                if clear and not inside_view(camera, start[None])[0] and speed < MAX_SPEED:
                    break
            positions[i] = start
            heading += math.radians(rng.normal(0.0, 3.0))
            velocities[i, :2] = speed * np.array([math.cos(heading), math.sin(heading)])
    positions[:, 2] = OBJECT_HALF_SIZE
    # Entering objects start throughout the video; late ones collide after it
    # ends and give the predictive questions their future.
    launch_frames = [int(rng.integers(0, 125)) if role == "entering" else 0 for role in roles]

    objects = tuple(
        ObjectSpec(
            object_id=i,
            color=attributes[i][0],
            material=attributes[i][1],
            shape=attributes[i][2],
            position=tuple(float(v) for v in positions[i]),
            velocity=tuple(float(v) for v in velocities[i]),
            yaw=float(yaws[i]),
            mass=float(params[i]["mass"]),
            friction=float(params[i]["friction"]),
            rolling_friction=float(params[i]["rolling_friction"]),
            torsional_friction=float(params[i]["torsional_friction"]),
            restitution=float(params[i]["restitution"]),
            role=roles[i],
            launch_frame=launch_frames[i],
        )
        for i in range(count)
    )
    return SceneSpec(scene_index=scene_index, camera=camera, objects=objects, look=look)
