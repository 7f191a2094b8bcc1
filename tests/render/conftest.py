"""A seven-object world for the render and viewer tests: the shared six-object world plus a cyan cube."""

from __future__ import annotations

from dataclasses import replace

import pytest

from world.types import Body, BodyState, Shape, World


def seven_object_world(scene_builders) -> World:
    six = scene_builders.six_object_world()
    cube = Body(6, Shape("cube", half_extent=0.25), BodyState((1.5, 2.2, 0.25), (-1.2, -0.4, 0.0), yaw=0.5),
                mass=2.0, friction=0.25, restitution=0.7, color="cyan", material="rubber")
    return replace(six, bodies=(*six.bodies, cube), id="seven-objects")


@pytest.fixture(scope="session")
def seven_world(scene_builders) -> World:
    return seven_object_world(scene_builders)
