"""Small world builders shared by the engine tests."""

from __future__ import annotations

from world.types import Body, BodyState, Shape, World

CYLINDER = Shape("cylinder", radius=0.2, half_height=0.1)
CUBE = Shape("cube", half_extent=0.2)
SPHERE = Shape("sphere", radius=0.2)


def body(body_id: int, xy, velocity=(0.0, 0.0), shape: Shape = CYLINDER, yaw: float = 0.0,
         yaw_rate: float = 0.0, **params) -> Body:
    """A body resting on the plane at ``xy`` (m) with horizontal ``velocity`` (m/s)."""
    state = BodyState((float(xy[0]), float(xy[1]), shape.rest_height),
                      (float(velocity[0]), float(velocity[1]), 0.0), yaw=yaw, yaw_rate=yaw_rate)
    return Body(body_id, shape, state, **params)


def world_of(*bodies: Body, **kwargs) -> World:
    kwargs.setdefault("observed_frames", 128)
    return World(tuple(bodies), **kwargs)
