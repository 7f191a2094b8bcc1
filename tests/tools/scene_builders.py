"""Hand-built worlds for the tool and server tests (no perception, no fitting).

``six_object_world``: a chain of three cylinders and a cube on the plane
(0 -> 1 -> 2 -> 3 collisions), a sphere that enters later and hits the cube
(3 -> 4), and a sphere that slides out of view without touching anything. A camera looking at the
origin gives in/out-of-view events.
"""

from __future__ import annotations

import numpy as np

from world.camera import look_at_camera
from world.types import Body, BodyState, Rollout, Shape, World


def six_object_world(with_camera: bool = True) -> World:
    cyl = Shape("cylinder", radius=0.2, half_height=0.2)
    ball = Shape("sphere", radius=0.2)
    bodies = (
        Body(0, cyl, BodyState((-2.0, 0.0, 0.2), (3.0, 0.0, 0.0)), mass=1.0, friction=0.1, restitution=0.9, color="red", material="metal"),
        Body(1, cyl, BodyState((-0.8, 0.0, 0.2)), mass=1.0, friction=0.1, restitution=0.9, color="blue", material="rubber"),
        Body(2, cyl, BodyState((0.2, 0.0, 0.2)), mass=1.0, friction=0.1, restitution=0.9, color="green", material="metal"),
        Body(3, Shape("cube", half_extent=0.2), BodyState((1.2, 0.0, 0.2), yaw=0.3), mass=1.0, friction=0.2, restitution=0.9, color="yellow", material="rubber"),
        Body(4, ball, BodyState((1.97, -3.0, 0.2), (0.0, 3.5, 0.0), time=1.0), mass=0.5, friction=0.15, restitution=0.8, color="purple", material="metal"),
        Body(5, ball, BodyState((-3.0, 2.5, 0.2), (-3.0, 0.5, 0.0)), mass=1.0, friction=0.05, restitution=0.8, color="gray", material="rubber"),
    )
    camera = look_at_camera((0.0, -9.0, 6.0), (0.0, 0.0, 0.0)) if with_camera else None
    return World(bodies=bodies, fps=25.0, observed_frames=128, camera=camera, id="six-objects",
                 provenance={"fit_error": {"rmse_m": 0.012, "frames": 128}})


def two_cube_world() -> World:
    """Two cubes (ids 7 and 9) and a sphere (id 11); positions come from hand-made rollouts."""
    cube = Shape("cube", half_extent=0.2)
    return World(
        bodies=(
            Body(7, cube, BodyState((0.0, 0.0, 0.2))),
            Body(9, cube, BodyState((1.0, 0.0, 0.2))),
            Body(11, Shape("sphere", radius=0.2), BodyState((0.0, 2.0, 0.2))),
        ),
        fps=10.0, observed_frames=8, id="hand-made",
    )


def hand_rollout(world: World, rollout_id: str, positions, events=(), edits=(), active=None):
    """A Rollout with given per-frame positions (T, N, 3) m in ``world.body_ids`` order; zero velocities and yaw."""
    positions = np.asarray(positions, dtype=float)
    frames, count = positions.shape[:2]
    active = np.ones((frames, count), dtype=bool) if active is None else np.asarray(active, dtype=bool)
    return Rollout(
        id=rollout_id, world_id=world.id, edits=tuple(edits), fps=world.fps, observed_frames=world.observed_frames,
        body_ids=world.body_ids, times=np.arange(frames) / world.fps, positions=positions,
        velocities=np.zeros_like(positions), yaw=np.zeros((frames, count)), active=active, visible=active.copy(),
        events=tuple(events),
    )
