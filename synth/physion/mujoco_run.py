"""MJCF, simulation and rendering of Physion-style trials (one MuJoCo model per phase).

Contacts are explicit pairs (every geom has contype 0):

* body-static: the body's Coulomb friction (condim 3; condim 1 when it is 0);
  a body with restitution e > 0 bounces on a linear spring-damper contact
  whose damping ratio gives e (``synth.mjcf.contact_stiffness_damping``),
  otherwise the contact is critically damped (no bounce).
* body-body: frictionless (condim 1), spring-damper with the trial's pair restitution.

Zones are visual only; touching one is decided geometrically from MuJoCo's
states at every physics step (``world.scene3d.motion.gap_to_static``).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import mujoco
import numpy as np

from synth.mjcf import TIMESTEP, contact_stiffness_damping
from synth.physion.spec import FPS, PhaseSpec, TrialSpec
from synth.scene import COLOR_RGB, camera_fovy_deg
from world.scene3d.motion import ZONE_TOUCH_TOLERANCE, gap_to_static
from world.scene3d.types import StaticBox
from world.types import STANDARD_GRAVITY

STEPS_PER_FRAME = int(round(1.0 / (FPS * TIMESTEP)))
STATIC_RGBA = {"floor": "0.55 0.55 0.56 1", "platform": "0.45 0.36 0.28 1", "ramp": "0.5 0.42 0.3 1",
               "wall": "0.4 0.45 0.5 1", "pillar": "0.4 0.4 0.4 1", "zone": "1 0.93 0.2 1"}
CURTAIN_RGB = (52, 58, 70)  # the curtain covers the whole view while objects are rearranged
MARGIN = 0.03  # m: a label must not change when the patient grows or shrinks this much sideways


def _fmt(values) -> str:
    return " ".join(f"{float(v):.9g}" for v in values)


def _wxyz(quat_xyzw) -> list[float]:
    x, y, z, w = quat_xyzw
    return [w, x, y, z]


def _rgba(color: str) -> str:
    r, g, b = COLOR_RGB[color]
    return _fmt([r / 255.0, g / 255.0, b / 255.0, 1.0])


def build_phase_xml(trial: TrialSpec, phase: PhaseSpec) -> tuple[str, tuple[int, ...]]:
    """MJCF of one phase and the body ids in body order."""
    present = [b for b in trial.bodies if b.id in dict(phase.states)]
    orientations = dict(phase.orientations)
    states = dict(phase.states)
    cam = trial.camera
    rot = cam.rotation
    x_axis = [rot[0][0], rot[1][0], rot[2][0]]
    y_axis = [-rot[0][1], -rot[1][1], -rot[2][1]]
    statics = []
    for box in phase.static_objects:
        statics.append(f'<geom name="static{box.id}" type="box" pos="{_fmt(box.center)}" size="{_fmt(box.half_extents)}" '
                       f'quat="{_fmt(_wxyz(box.orientation))}" rgba="{STATIC_RGBA[box.role]}" contype="0" conaffinity="0"/>')
    bodies = []
    for body in present:
        kind, size = ("sphere", [body.half_size]) if body.shape == "sphere" else ("box", [body.half_size] * 3)
        quat = _wxyz(orientations.get(body.id, (0.0, 0.0, 0.0, 1.0)))
        bodies.append(f'<body name="body{body.id}" pos="{_fmt(states[body.id].position)}" quat="{_fmt(quat)}">'
                      f'<freejoint/><geom name="geom{body.id}" type="{kind}" size="{_fmt(size)}" mass="{body.mass:.9g}" '
                      f'rgba="{_rgba(body.color)}" contype="0" conaffinity="0"/></body>')
    pairs = []
    for body in present:
        for box in phase.static_objects:
            if box.role == "zone":
                continue
            condim = 3 if body.friction > 0 else 1
            if body.restitution > 0:
                stiffness, damping = contact_stiffness_damping(body.restitution)
                solref, solimp = _fmt([-stiffness, -damping]), ' solimp="0.99 0.99 0.001"'
            else:
                solref, solimp = "0.01 1", ""
            pairs.append(f'<pair geom1="static{box.id}" geom2="geom{body.id}" condim="{condim}" '
                         f'friction="{_fmt([body.friction, body.friction, 0, 0, 0])}" solref="{solref}"{solimp}/>')
    for n, a in enumerate(present):
        for b in present[n + 1:]:
            stiffness, damping = contact_stiffness_damping(trial.pair_restitution)
            pairs.append(f'<pair geom1="geom{a.id}" geom2="geom{b.id}" condim="1" solref="{_fmt([-stiffness, -damping])}" '
                         f'solimp="0.99 0.99 0.001"/>')
    xml = f"""<mujoco model="physion_{trial.category}_{trial.index:05d}">
  <option timestep="{TIMESTEP}" integrator="implicitfast" cone="elliptic" gravity="0 0 {-STANDARD_GRAVITY}"/>
  <visual>
    <global offwidth="{cam.width}" offheight="{cam.height}"/>
    <quality shadowsize="2048" offsamples="4"/>
    <headlight ambient="0.35 0.35 0.35" diffuse="0.3 0.3 0.3" specular="0.1 0.1 0.1"/>
    <map znear="0.05" zfar="80"/>
  </visual>
  <worldbody>
    <light name="key" directional="true" pos="-3 -4 8" dir="0.35 0.45 -1" diffuse="0.55 0.55 0.55" castshadow="true"/>
    <camera name="main" pos="{_fmt(cam.position)}" xyaxes="{_fmt(x_axis + y_axis)}" fovy="{camera_fovy_deg(cam):.9g}"/>
    {chr(10).join(statics)}
    {chr(10).join(bodies)}
  </worldbody>
  <contact>
    {chr(10).join(pairs)}
  </contact>
</mujoco>
"""
    return xml, tuple(b.id for b in present)


@dataclass(frozen=True)
class PhaseRun:
    """MuJoCo states of one phase.

    frame_ids: (F,) absolute frames. positions/velocities: (F, N, 3); quaternions: (F, N, 4) x y z w;
    step_times: (S,) absolute s; step_positions: (S, N, 3); contact_steps: (S,) bool, agent and
    patient bodies in MuJoCo contact. qpos: (F, 7N) for rendering.
    """

    body_ids: tuple[int, ...]
    frame_ids: np.ndarray
    positions: np.ndarray
    quaternions: np.ndarray
    velocities: np.ndarray
    qpos: np.ndarray
    step_times: np.ndarray
    step_positions: np.ndarray
    contact_steps: np.ndarray
    xml: str
    impacts: tuple[tuple[float, float], ...] = ()  # (time s, realised restitution) of the agent's static impacts


def run_phase(trial: TrialSpec, phase: PhaseSpec, last_frame: int) -> PhaseRun:
    """Simulate ``phase`` from its first frame to ``last_frame`` (inclusive), recording every step."""
    xml, ids = build_phase_xml(trial, phase)
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    states = dict(phase.states)
    for k, body_id in enumerate(ids):
        data.qvel[6 * k: 6 * k + 3] = states[body_id].velocity
    mujoco.mj_forward(model, data)
    agent = next((b.id for b in trial.bodies if b.role == "agent"), None)
    patient = next((b.id for b in trial.bodies if b.role == "patient"), None)
    geom_agent = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, f"geom{agent}") if agent in ids else -2
    geom_patient = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, f"geom{patient}") if patient in ids else -2
    frames = last_frame - phase.first_frame + 1
    n = len(ids)
    positions, quats, velocities = np.zeros((frames, n, 3)), np.zeros((frames, n, 4)), np.zeros((frames, n, 3))
    qpos = np.zeros((frames, model.nq))
    total_steps = (frames - 1) * STEPS_PER_FRAME + 1
    step_positions = np.zeros((total_steps, n, 3))
    contact = np.zeros(total_steps, bool)
    static_geoms = {mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, f"static{b.id}") for b in phase.static_objects}
    k_agent = ids.index(agent) if agent in ids else None
    agent_velocity = np.zeros((total_steps, 3))
    agent_normal = np.full((total_steps, 3), np.nan)  # normal of the agent's static contact, NaN when none

    def record_step(s: int) -> None:
        step_positions[s] = data.qpos.reshape(n, 7)[:, :3]
        if k_agent is not None:
            agent_velocity[s] = data.qvel[6 * k_agent: 6 * k_agent + 3]
        for c in range(data.ncon):
            g1, g2 = int(data.contact[c].geom1), int(data.contact[c].geom2)
            if {g1, g2} == {geom_agent, geom_patient} and data.contact[c].dist <= 0:
                contact[s] = True
            if geom_agent in (g1, g2) and ({g1, g2} - {geom_agent}) <= static_geoms:
                normal = np.array(data.contact[c].frame[:3])  # from geom1 to geom2
                agent_normal[s] = normal if g1 != geom_agent else -normal

    for f in range(frames):
        if f > 0:
            for k in range(STEPS_PER_FRAME):
                mujoco.mj_step(model, data)
                record_step((f - 1) * STEPS_PER_FRAME + k + 1)
        else:
            record_step(0)
        q = data.qpos.reshape(n, 7)
        positions[f] = q[:, :3]
        quats[f] = q[:, [4, 5, 6, 3]]
        velocities[f] = data.qvel.reshape(n, 6)[:, :3]
        qpos[f] = data.qpos
    step_times = phase.start_time + np.arange(total_steps) * TIMESTEP
    return PhaseRun(ids, np.arange(phase.first_frame, last_frame + 1), positions, quats, velocities, qpos,
                    step_times, step_positions, contact, xml, _impacts(step_times, agent_velocity, agent_normal))


def _impacts(times: np.ndarray, velocity: np.ndarray, normal: np.ndarray) -> tuple[tuple[float, float], ...]:
    """Realised restitution of each static contact episode: -v.n just after / v.n just before.

    Episodes shorter than a resting contact; only impacts faster than 0.3 m/s count.
    """
    touching = ~np.isnan(normal[:, 0])
    out = []
    k = 1
    while k < len(times):
        if touching[k] and not touching[k - 1]:
            end = k
            while end < len(times) and touching[end]:
                end += 1
            n = normal[k]
            v_in = float(velocity[k - 1] @ n)  # n points from the surface to the agent
            if end < len(times) and v_in < -0.3:
                out.append((float(times[k]), float(-(velocity[end] @ n) / v_in)))
            k = end
        k += 1
    return tuple(out)


def run_trial(trial: TrialSpec) -> list[PhaseRun]:
    """Every phase: the earlier ones to their last frame, the last one to the horizon."""
    runs = []
    for k, phase in enumerate(trial.phases):
        last = phase.last_frame if k < len(trial.phases) - 1 else trial.horizon_frame
        runs.append(run_phase(trial, phase, last))
    return runs


def touch_steps(trial: TrialSpec, run: PhaseRun, grow: float = 0.0) -> np.ndarray:
    """(S,) bool: the agent touches the patient at each physics step of the last phase.

    A zone patient: geometric gap to the zone (grown sideways by ``grow`` m) within
    ZONE_TOUCH_TOLERANCE. A body patient: MuJoCo's own contact when grow == 0, else the
    gap to the patient box (grown sideways, rotation ignored) within 2 mm.
    """
    agent = next(b for b in trial.bodies if b.role == "agent")
    k_agent = run.body_ids.index(agent.id)
    centres = run.step_positions[:, k_agent]
    if trial.patient_zone is not None:
        zone = next(b for b in trial.phases[-1].static_objects if b.id == trial.patient_zone)
        half = np.array(zone.half_extents) + np.array([grow, grow, 0.0])
        return gap_to_static(agent, replace(zone, half_extents=tuple(np.maximum(half, 1e-4))), centres) <= ZONE_TOUCH_TOLERANCE
    if grow == 0.0:
        return run.contact_steps
    patient = next(b for b in trial.bodies if b.role == "patient")
    k_patient = run.body_ids.index(patient.id)
    half = max(patient.half_size + grow, 1e-4)
    out = np.zeros(len(centres), bool)
    for s in range(len(centres)):
        box = StaticBox(0, "pillar", run.step_positions[s, k_patient], (half, half, patient.half_size))
        out[s] = gap_to_static(agent, box, centres[s:s + 1])[0] <= 0.002
    return out


@dataclass(frozen=True)
class TrialOutcome:
    label: bool
    contact_time: float | None
    touched_before_boundary: bool
    robust: bool  # the label holds when the patient grows or shrinks by MARGIN sideways


def outcome(trial: TrialSpec, runs: list[PhaseRun]) -> TrialOutcome:
    run = runs[-1]
    boundary_time = trial.boundary_frame / FPS
    after = run.step_times > boundary_time
    touch = touch_steps(trial, run)
    label = bool(np.any(touch & after))
    time = float(run.step_times[np.argmax(touch & after)]) if label else None
    grown = bool(np.any(touch_steps(trial, run, MARGIN) & after))
    shrunk = bool(np.any(touch_steps(trial, run, -MARGIN) & after))
    return TrialOutcome(label, time, bool(np.any(touch & ~after)), grown == shrunk == label)


def render_trial(trial: TrialSpec, runs: list[PhaseRun]) -> np.ndarray:
    """(F, H, W, 3) uint8 frames 0..boundary_frame; curtain frames are a flat curtain colour."""
    cam = trial.camera
    count = trial.boundary_frame + 1
    rgb = np.empty((count, cam.height, cam.width, 3), np.uint8)
    rgb[:] = CURTAIN_RGB
    for phase, run in zip(trial.phases, runs):
        model = mujoco.MjModel.from_xml_string(run.xml)
        data = mujoco.MjData(model)
        renderer = mujoco.Renderer(model, height=cam.height, width=cam.width)
        try:
            for f, q in zip(run.frame_ids, run.qpos):
                if f >= count:
                    break
                data.qpos[:] = q
                mujoco.mj_forward(model, data)
                renderer.update_scene(data, camera="main")
                rgb[f] = renderer.render()
        finally:
            renderer.close()
    return rgb
