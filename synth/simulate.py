"""Run a scene in MuJoCo and extract per-frame states and events.

Ground truth comes only from MuJoCo: trajectories are MuJoCo's states sampled
at every video frame, and collisions are MuJoCo contacts between two object
geoms (the first contact of each distinct contact episode).
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from synth.mjcf import build_mjcf
from synth.scene import ObjectSpec, SceneSpec, inside_view
from world.timebase import CONTACT_EPISODE_GAP_SECONDS, frame_of
from world.types import Event

# Two touches of one pair less than this far apart are one collision (a
# resting contact or a grazing slide flickers on and off between steps).
DEBOUNCE_SECONDS = CONTACT_EPISODE_GAP_SECONDS


@dataclass(frozen=True)
class SimResult:
    """MuJoCo states at every frame 0..T-1 of one run of a scene.

    object_ids: (N,) ids of the simulated objects (a removed object is absent).
    qpos: (T, 7N) MuJoCo generalized positions, for rendering.
    positions: (T, N, 3) m, world frame. quaternions: (T, N, 4) (x, y, z, w).
    velocities: (T, N, 3) m/s. angular_velocities: (T, N, 3) rad/s, world frame.
    visible: (T, N) bool, object centre inside the camera image.
    events: collisions, in and out events in frame order (world.types.Event;
    for collisions ``position`` is MuJoCo's contact point).
    """

    object_ids: tuple[int, ...]
    qpos: np.ndarray
    positions: np.ndarray
    quaternions: np.ndarray
    velocities: np.ndarray
    angular_velocities: np.ndarray
    visible: np.ndarray
    events: tuple[Event, ...]
    fps: float

    @property
    def collisions(self) -> tuple[Event, ...]:
        return tuple(e for e in self.events if e.kind == "collision")


def load_model(spec: SceneSpec, removed: int | None = None) -> tuple[mujoco.MjModel, tuple[int, ...]]:
    built = build_mjcf(spec, removed)
    return mujoco.MjModel.from_xml_string(built.xml, built.assets or None), built.object_ids


def _launch(data: mujoco.MjData, k: int, obj: ObjectSpec) -> None:
    """Impart the object's launch velocity (body k of the model)."""
    v = np.array(obj.velocity, dtype=float)
    data.qvel[6 * k : 6 * k + 3] = v
    if obj.shape == "sphere":
        # Launch spheres already rolling (omega = z x v / r) so they decelerate
        # by rolling resistance from the first frame, with no sliding phase.
        omega_world = np.cross([0.0, 0.0, 1.0], v) / obj.half_size
        world_from_body = data.xmat[k + 1].reshape(3, 3)
        data.qvel[6 * k + 3 : 6 * k + 6] = world_from_body.T @ omega_world  # free joints use body-frame omega
    else:
        data.qvel[6 * k + 3 : 6 * k + 6] = 0.0


def simulate(spec: SceneSpec, removed: int | None = None, horizon_frames: int | None = None) -> SimResult:
    """Simulate the scene (optionally without object ``removed``) for ``horizon_frames`` frames."""
    model, object_ids = load_model(spec, removed)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    by_id = {o.object_id: o for o in spec.objects}
    launches: dict[int, list[int]] = {}
    for k, oid in enumerate(object_ids):
        launches.setdefault(by_id[oid].launch_frame, []).append(k)
    frames = spec.horizon_frames if horizon_frames is None else int(horizon_frames)
    n = len(object_ids)
    steps_per_frame = int(round(1.0 / (spec.fps * model.opt.timestep)))
    geom_to_object = np.full(model.ngeom, -1, dtype=int)
    for k, oid in enumerate(object_ids):
        geom_to_object[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, f"geom{oid}")] = oid

    qpos = np.zeros((frames, model.nq))
    positions = np.zeros((frames, n, 3))
    quats = np.zeros((frames, n, 4))
    velocities = np.zeros((frames, n, 3))
    angular = np.zeros((frames, n, 3))
    last_touch: dict[tuple[int, int], float] = {}
    collisions: list[Event] = []
    for frame in range(frames):
        for k in launches.get(frame, ()):
            _launch(data, k, by_id[object_ids[k]])
        if frame in launches:
            mujoco.mj_forward(model, data)
        qpos[frame] = data.qpos
        for k in range(n):
            body = k + 1
            positions[frame, k] = data.xpos[body]
            w, x, y, z = data.xquat[body]
            quats[frame, k] = (x, y, z, w)
            velocities[frame, k] = data.qvel[6 * k : 6 * k + 3]
            angular[frame, k] = data.xmat[body].reshape(3, 3) @ data.qvel[6 * k + 3 : 6 * k + 6]
        if frame == frames - 1:
            break
        for _ in range(steps_per_frame):
            # Contacts found by this step's collision detection belong to its start time.
            contact_time = data.time
            mujoco.mj_step(model, data)
            for c in range(data.ncon):
                contact = data.contact[c]
                a, b = geom_to_object[contact.geom[0]], geom_to_object[contact.geom[1]]
                if a < 0 or b < 0 or contact.dist > 0:
                    continue
                pair = (int(min(a, b)), int(max(a, b)))
                previous = last_touch.get(pair)
                if previous is None or contact_time - previous > DEBOUNCE_SECONDS:
                    collisions.append(
                        Event(
                            kind="collision",
                            bodies=pair,
                            time=float(contact_time),
                            frame=frame_of(contact_time, spec.fps),
                            position=tuple(float(v) for v in contact.pos),
                        )
                    )
                last_touch[pair] = contact_time
    visible = inside_view(spec.camera, positions.reshape(-1, 3)).reshape(frames, n)
    events = collisions + in_out_events(visible, object_ids, positions, spec.fps)
    events.sort(key=lambda e: (e.frame, e.kind, e.bodies))
    return SimResult(
        object_ids=object_ids,
        qpos=qpos,
        positions=positions,
        quaternions=quats,
        velocities=velocities,
        angular_velocities=angular,
        visible=visible,
        events=tuple(events),
        fps=spec.fps,
    )


def in_out_events(visible: np.ndarray, object_ids: tuple[int, ...], positions: np.ndarray, fps: float) -> list[Event]:
    """In/out events from visibility (T, N): ``in`` at the first visible frame of an
    object that was out of view the frame before (objects visible at frame 0 do
    not enter), ``out`` at the first frame no longer visible."""
    events: list[Event] = []
    for k, oid in enumerate(object_ids):
        changes = np.nonzero(visible[1:, k] != visible[:-1, k])[0] + 1
        for frame in changes:
            kind = "in" if visible[frame, k] else "out"
            events.append(
                Event(kind=kind, bodies=(int(oid),), time=float(frame / fps), frame=int(frame), position=tuple(float(v) for v in positions[frame, k]))
            )
    return events
