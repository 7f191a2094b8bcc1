"""Hand-built worlds for the tool and server tests (no perception, no fitting).

``six_object_world``: a chain of three cylinders and a cube on the plane
(0 -> 1 -> 2 -> 3 collisions), a sphere that enters later and hits the cube
(3 -> 4), and a sphere that slides out of view without touching anything. A camera looking at the
origin gives in/out-of-view events.

``sliding_world3d``: a 3D world (world.scene3d) where a red cube slides on the
floor with Coulomb friction towards a resting yellow cube and past a zone, with
a fitted friction recorded, anchored at t = 1 s (frame 25 of a 25 fps video).
"""

from __future__ import annotations

import numpy as np

from world.camera import look_at_camera
from world.scene3d.types import Anchor3D, Body3D, FittedProperty, Phase3D, State3D, StaticBox, World3D
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


SLIDE_SPEED = 2.0  # m/s of the red cube at the anchor
SLIDE_FRICTION = 0.3
CUBE_HALF = 0.1  # m
ANCHOR_TIME = 1.0  # s


def sliding_world3d(patient_x: float, zone_x: float | None = None) -> World3D:
    """Red cube 0 at x = 0 sliding at SLIDE_SPEED along +x (friction SLIDE_FRICTION) at ANCHOR_TIME; yellow cube 1
    resting at ``patient_x``; with ``zone_x`` a zone patch 101 (0.1 m half length in x) centred there is the patient."""
    floor = StaticBox(100, "floor", (0.0, 0.0, -0.5), (10.0, 10.0, 0.5))
    statics = (floor,) if zone_x is None else (floor, StaticBox(101, "zone", (zone_x, 0.0, 0.001), (0.1, 0.3, 0.001)))
    bodies = (Body3D(0, "cube", CUBE_HALF, mass=1.0, friction=SLIDE_FRICTION, role="agent", color="red"),
              Body3D(1, "cube", CUBE_HALF, mass=1.0, friction=0.5, role=None if zone_x is not None else "patient", color="yellow"))
    at_anchor = ((0, State3D((0.0, 0.0, CUBE_HALF), (SLIDE_SPEED, 0.0, 0.0))), (1, State3D((patient_x, 0.0, CUBE_HALF))))
    start = ((0, State3D((-1.0, 0.0, CUBE_HALF), (SLIDE_SPEED, 0.0, 0.0))), (1, State3D((patient_x, 0.0, CUBE_HALF))))
    return World3D(bodies, (Phase3D(0.0, statics, start),), patient_zone=None if zone_x is None else 101, fps=25.0,
                   anchor=Anchor3D(ANCHOR_TIME, at_anchor), horizon_frames=100,
                   fitted=(FittedProperty("friction", 0, SLIDE_FRICTION, 0.002, 12),))
