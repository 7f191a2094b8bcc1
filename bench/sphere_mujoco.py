"""A single sphere on the generator's floor in MuJoCo (synth.mjcf's contacts), launched
with a chosen linear velocity and spin: ground truth for the skid-then-roll law."""

from __future__ import annotations

import mujoco
import numpy as np

from synth.scene import OBJECT_HALF_SIZE, ObjectSpec, SceneSpec, camera_look_at
from synth.simulate import load_model


def sphere_spec(friction: float, rolling_friction: float, torsional_friction: float) -> SceneSpec:
    """One rubber sphere at the origin with the generator's contact parameters."""
    camera = camera_look_at(np.array([0.0, -6.0, 4.0]), np.array([0.0, 0.0, 0.0]), 36.0)
    sphere = ObjectSpec(0, "red", "rubber", "sphere", (0.0, 0.0, OBJECT_HALF_SIZE), (0.0, 0.0, 0.0), 0.0,
                        mass=0.04, friction=friction, rolling_friction=rolling_friction,
                        torsional_friction=torsional_friction, restitution=0.7, role="moving")
    return SceneSpec(0, camera, (sphere,))


def run_sphere(spec: SceneSpec, velocity: tuple[float, float], spin_velocity: tuple[float, float],
               duration: float, fps: float = 25.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Launch the sphere at t = 0 with planar ``velocity`` (m/s) and the spin whose rolling
    velocity is ``spin_velocity`` (m/s, (omega x r e_z)_xy). Returns per frame (F,) times s,
    (F, 2) positions m and (F, 2) slip velocities m/s of the contact point."""
    model, _ = load_model(spec)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    radius = OBJECT_HALF_SIZE
    # omega x (0, 0, r) = (omega_y r, -omega_x r, 0) = spin_velocity
    omega = np.array([-spin_velocity[1] / radius, spin_velocity[0] / radius, 0.0])
    data.qvel[0:3] = (velocity[0], velocity[1], 0.0)
    data.qvel[3:6] = data.xmat[1].reshape(3, 3).T @ omega  # free joints take body-frame omega
    mujoco.mj_forward(model, data)
    steps = int(round(1.0 / (fps * model.opt.timestep)))
    frames = int(round(duration * fps)) + 1
    times, positions, slips = np.zeros(frames), np.zeros((frames, 2)), np.zeros((frames, 2))
    for frame in range(frames):
        times[frame] = data.time
        positions[frame] = data.xpos[1][:2]
        w = data.xmat[1].reshape(3, 3) @ data.qvel[3:6]
        rolling = np.cross(w, [0.0, 0.0, radius])[:2]
        slips[frame] = data.qvel[0:2] - rolling
        for _ in range(steps):
            mujoco.mj_step(model, data)
    return times, positions, slips
