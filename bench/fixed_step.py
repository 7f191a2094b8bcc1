"""A fixed-step integrator of the SAME model as the event-driven engine.

The baseline of the paper's ablation (Appendix A.2): Coulomb deceleration
``mu g`` that stops a body instead of reversing it, and the normal impulse
``j = -(1+e)(v_i-v_j).n / (1/m_i+1/m_j)`` applied when a pair overlaps
while approaching, with semi-implicit Euler at step ``dt``. Footprints and
their exact distances come from ``world.contacts`` so that only the time
discretisation differs. Yaw is held (no spin), as identification does not
fit it. Returns a ``Rollout`` (collision events only, no in/out/stop), so the
identification code and the metrics can swap it in for ``world.rollout.simulate``.
"""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np

from world.contacts import footprint_distance
from world.edits import apply_edits
from world.rollout import default_horizon, footprint_of, pair_restitution
from world.timebase import frame_of
from world.types import Edit, Event, Rollout, World


def simulate_fixed_step(
    world: World,
    edits: Sequence[Edit] = (),
    horizon_frames: int | None = None,
    rollout_id: str = "fixed-step",
    dt: float = 0.01,
) -> Rollout:
    """Integrate ``world`` at step ``dt`` (s); sample every frame (frame times must be multiples of dt)."""
    edited = apply_edits(world, tuple(edits))
    horizon = default_horizon(edited) if horizon_frames is None else int(horizon_frames)
    bodies = edited.bodies
    n = len(bodies)
    footprints = [footprint_of(b) for b in bodies]
    pair_e = pair_restitution(edited)
    mass = np.array([b.mass for b in bodies])
    deceleration = np.array([b.friction for b in bodies]) * edited.gravity  # m/s^2
    position = np.array([b.initial.position[:2] for b in bodies], dtype=float).reshape(n, 2)
    velocity = np.array([b.initial.velocity[:2] for b in bodies], dtype=float).reshape(n, 2)
    yaw = np.array([b.initial.yaw for b in bodies], dtype=float)
    height = np.array([b.shape.rest_height for b in bodies])
    start = np.array([b.initial.time for b in bodies])
    stop = np.array([math.inf if b.active_until is None else b.active_until for b in bodies])
    steps_per_frame = max(1, int(round(1.0 / (edited.fps * dt))))
    step = 1.0 / (edited.fps * steps_per_frame)

    positions = np.zeros((horizon, n, 3))
    velocities = np.zeros((horizon, n, 3))
    active = np.zeros((horizon, n), dtype=bool)
    touching: set[tuple[int, int]] = set()
    events: list[Event] = []
    for frame in range(horizon):
        for sub in range(steps_per_frame if frame else 0):
            t = (frame - 1) * steps_per_frame * step + (sub + 1) * step
            live = (start <= t + 1e-12) & (t < stop)
            speed = np.linalg.norm(velocity, axis=1)
            slow_down = deceleration * step  # never reverses: a body slower than this stops
            scale = np.where(speed <= slow_down, 0.0, 1.0 - slow_down / np.maximum(speed, 1e-300))
            velocity = np.where(live[:, None], velocity * scale[:, None], velocity)
            position = np.where(live[:, None], position + velocity * step, position)
            ids = np.flatnonzero(live)
            now_touching: set[tuple[int, int]] = set()
            for x in range(len(ids)):
                for y in range(x + 1, len(ids)):
                    a, b = int(ids[x]), int(ids[y])
                    gap, normal, point = footprint_distance(
                        footprints[a], position[a, 0], position[a, 1], yaw[a],
                        footprints[b], position[b, 0], position[b, 1], yaw[b],
                    )
                    if gap >= 0:
                        continue
                    now_touching.add((a, b))
                    n_vec = np.asarray(normal)  # from b to a
                    approach = (velocity[a] - velocity[b]) @ n_vec
                    if approach >= 0:
                        continue
                    key = (min(bodies[a].id, bodies[b].id), max(bodies[a].id, bodies[b].id))
                    e = pair_e.get(key, min(bodies[a].restitution, bodies[b].restitution))
                    impulse = -(1 + e) * approach / (1 / mass[a] + 1 / mass[b])
                    velocity[a] += impulse / mass[a] * n_vec
                    velocity[b] -= impulse / mass[b] * n_vec
                    if (a, b) not in touching:
                        events.append(Event("collision", key, t, frame_of(t, edited.fps), (point[0], point[1], 0.0), float(impulse)))
            touching = now_touching
        t = frame / edited.fps
        live = (start <= t + 1e-12) & (t < stop)
        active[frame] = live
        positions[frame, :, :2] = position
        positions[frame, :, 2] = height
        velocities[frame, :, :2] = np.where(live[:, None], velocity, 0.0)
    times = np.arange(horizon) / edited.fps
    return Rollout(
        id=rollout_id, world_id=world.id, edits=tuple(edits), fps=edited.fps, observed_frames=edited.observed_frames,
        body_ids=edited.body_ids, times=times, positions=positions, velocities=velocities,
        yaw=np.broadcast_to(yaw, (horizon, n)).copy(), active=active, visible=active.copy(), events=tuple(events),
    )
