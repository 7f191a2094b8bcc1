"""Run a PhysMind World in MuJoCo (an independent engine) for agreement tests.

How the parameters are matched (measured with MuJoCo 4.0.0, see docs/engine.md):

* Every contact is an explicit ``<pair>`` (all geoms have contype = conaffinity = 0),
  so each body-floor and body-body contact gets its own parameters.
* ``cone="elliptic"``: the default pyramidal cone lets diagonal sliding
  decelerate at only mu*g/sqrt(2) (measured), the elliptic cone is isotropic.
* Body-floor: ``condim=3`` (sliding friction only), ``friction = mu`` of the body,
  ``solref="0.005 1"`` (critically damped, stiff). With ``timestep = 2e-4`` the
  measured sliding deceleration of a cylinder or box is within 0.3 % of mu*g.
* Body-body: ``condim=1`` (frictionless normal contact, like our central
  impulse), ``solref="-100000 -50"`` (direct stiffness/damping, mass independent).
  Its effective restitution is not a MuJoCo input, so ``measure_restitution``
  measures it on a separate head-on calibration run and the engine is given
  that ``e`` for the corresponding pair of shapes.
* Bodies are cylinders (flat, radius 0.2 m, half-height 0.1 m) and boxes: they
  slide instead of rolling, so both engines model the same motion.
* The bodies first settle on the floor for ``SETTLE_TIME`` s at rest; time 0
  of the comparison is when the initial velocities are applied.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from world.types import World

TIMESTEP = 2e-4  # s
SETTLE_TIME = 0.1  # s
FLOOR_SOLREF = "0.005 1"
BODY_SOLREF = "-100000 -50"


def _geom_xml(name: str, body) -> str:
    shape = body.shape
    common = f'name="{name}" mass="{body.mass}" contype="0" conaffinity="0"'
    if shape.kind == "cylinder":
        return f'<geom type="cylinder" size="{shape.radius} {shape.half_height}" {common}/>'
    if shape.kind == "cube":
        h = shape.half_extent
        return f'<geom type="box" size="{h} {h} {h}" {common}/>'
    raise ValueError(f"mujoco_scenes: only cylinders and cubes slide in MuJoCo, got {shape.kind}")


def world_to_mjcf(world: World) -> str:
    """MJCF text for a world whose bodies all start at t = 0 on the plane."""
    bodies_xml, pairs_xml = [], []
    for body in world.bodies:
        x, y, z = body.initial.position
        yaw = body.initial.yaw
        quat = f"{np.cos(yaw / 2)} 0 0 {np.sin(yaw / 2)}"  # MuJoCo quaternions are (w, x, y, z)
        bodies_xml.append(f'<body name="body{body.id}" pos="{x} {y} {z}" quat="{quat}"><freejoint/>'
                          f'{_geom_xml(f"geom{body.id}", body)}</body>')
        mu = body.friction
        pairs_xml.append(f'<pair geom1="floor" geom2="geom{body.id}" condim="3" '
                         f'friction="{mu} {mu} 0.005 0.0001 0.0001" solref="{FLOOR_SOLREF}"/>')
    ids = [b.id for b in world.bodies]
    for i, a in enumerate(ids):
        for b in ids[i + 1:]:
            pairs_xml.append(f'<pair geom1="geom{a}" geom2="geom{b}" condim="1" solref="{BODY_SOLREF}"/>')
    return (f'<mujoco><option timestep="{TIMESTEP}" cone="elliptic" gravity="0 0 {-world.gravity}"/>'
            f'<worldbody><geom name="floor" type="plane" size="20 20 0.1" contype="0" conaffinity="0"/>'
            f'{"".join(bodies_xml)}</worldbody><contact>{"".join(pairs_xml)}</contact></mujoco>')


@dataclass(frozen=True)
class MujocoRun:
    """collisions: [(time s, (id_a, id_b))] contact onsets in time order; final: {id: (x, y)} m."""

    collisions: list[tuple[float, tuple[int, int]]]
    final: dict[int, tuple[float, float]]
    relative_speeds: list[tuple[float, float]]  # (approach speed before, separation speed after) per collision


def run_in_mujoco(world: World, duration: float) -> MujocoRun:
    """Simulate ``world`` for ``duration`` s after settling; contact onsets of body pairs are collisions."""
    model = mujoco.MjModel.from_xml_string(world_to_mjcf(world))
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    for _ in range(int(round(SETTLE_TIME / TIMESTEP))):
        mujoco.mj_step(model, data)
    body_ids = [b.id for b in world.bodies]
    geom_to_id = {model.geom(f"geom{i}").id: i for i in body_ids}
    for k, body in enumerate(world.bodies):
        data.qvel[6 * k:6 * k + 3] = body.initial.velocity
        data.qvel[6 * k + 3:6 * k + 6] = 0.0
    start = data.time
    in_contact: dict[tuple[int, int], bool] = {}
    onsets: list[tuple[float, tuple[int, int]]] = []
    speeds: list[tuple[float, float]] = []
    open_onset: dict[tuple[int, int], float] = {}

    def relative_speed(a: int, b: int) -> float:
        ka, kb = body_ids.index(a), body_ids.index(b)
        pa, pb = data.qpos[7 * ka:7 * ka + 2], data.qpos[7 * kb:7 * kb + 2]
        n = (pa - pb) / np.linalg.norm(pa - pb)
        return float((data.qvel[6 * ka:6 * ka + 2] - data.qvel[6 * kb:6 * kb + 2]) @ n)

    previous_speed: dict[tuple[int, int], float] = {}
    steps = int(round(duration / TIMESTEP))
    for _ in range(steps):
        for a_i, a in enumerate(body_ids):
            for b in body_ids[a_i + 1:]:
                previous_speed[(a, b)] = relative_speed(a, b)
        mujoco.mj_step(model, data)
        now = set()
        geoms = data.contact.geom[:data.ncon]
        for g1, g2 in geoms:
            if g1 in geom_to_id and g2 in geom_to_id:
                pair = tuple(sorted((geom_to_id[g1], geom_to_id[g2])))
                now.add(pair)
        for pair in now:
            if not in_contact.get(pair, False):
                onsets.append((data.time - start, pair))
                open_onset[pair] = previous_speed[pair]
        for pair, was in list(in_contact.items()):
            if was and pair not in now and pair in open_onset:
                speeds.append((-open_onset.pop(pair), relative_speed(*pair)))
        in_contact = {pair: pair in now for pair in set(in_contact) | now}
    final = {i: (float(data.qpos[7 * k]), float(data.qpos[7 * k + 1])) for k, i in enumerate(body_ids)}
    return MujocoRun(onsets, final, speeds)


def measure_restitution(world: World, duration: float = 1.0) -> float:
    """Effective restitution of MuJoCo's body-body contact: separation / approach speed of the first collision."""
    run = run_in_mujoco(world, duration)
    if not run.relative_speeds:
        raise RuntimeError("calibration scene produced no completed collision")
    approach, separation = run.relative_speeds[0]
    return separation / approach
