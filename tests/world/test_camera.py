"""Pinhole projection and CLEVRER-style in/out events."""

from __future__ import annotations

import numpy as np
import pytest

from tests.world.scenes import CUBE, body, world_of
from world.camera import centre_in_view, look_at_camera, project, view_events
from world.rollout import simulate
from world.types import Camera


def overhead_camera():
    # Looking straight down is not allowed by look_at (no roll reference): build it by hand.
    rotation = ((1.0, 0.0, 0.0), (0.0, -1.0, 0.0), (0.0, 0.0, -1.0))
    return Camera(width=200, height=100, fx=100.0, fy=100.0, cx=100.0, cy=50.0, position=(0.0, 0.0, 10.0),
                  rotation=rotation)


@pytest.mark.parametrize("point, pixel", [
    ((0.0, 0.0, 0.0), (100.0, 50.0)), ((1.0, 0.0, 0.0), (110.0, 50.0)), ((0.0, 2.0, 0.0), (100.0, 30.0)),
    ((-5.0, -2.5, 5.0), (0.0, 100.0)),
])
def test_project_matches_the_pinhole_formula(point, pixel):
    assert project(overhead_camera(), np.array([point]))[0] == pytest.approx(pixel)


def test_look_at_puts_the_target_at_the_principal_point():
    camera = look_at_camera((1.0, -5.0, 3.0), (0.5, 0.5, 0.0))
    assert project(camera, np.array([[0.5, 0.5, 0.0]]))[0] == pytest.approx((240.0, 160.0))
    behind = project(camera, np.array([[1.0, -10.0, 3.0]]))[0]
    assert np.isnan(behind).all()


def test_visibility_is_the_centre_in_the_image():
    camera = overhead_camera()  # sees x in [-10, 10), y in (-5, 5]
    centres = np.array([[9.9, 0.0, 0.0], [10.1, 0.0, 0.0], [0.0, 4.9, 0.0], [0.0, 5.1, 0.0], [0.0, 0.0, 11.0]])
    assert centre_in_view(camera, centres).tolist() == [True, False, True, False, False]  # the last one: behind


def test_a_body_resting_across_the_border_has_left_the_view_when_its_centre_has():
    # The generator's in/out events (CLEVRER's inside_camera_view) follow the centre: a cube that slides out
    # and stops with part of its footprint still in the picture has left the view, and the replay says so.
    camera = overhead_camera()
    world = world_of(body(0, (9.0, 0.0), (1.0, 0.0), shape=CUBE, friction=0.06), fps=25.0, camera=camera)
    rollout = simulate(world, horizon_frames=100)
    centre = rollout.positions[:, 0]
    near_edge = centre - (CUBE.half_extent, 0.0, 0.0)
    in_view = centre_in_view(camera, centre)
    assert in_view[0] and not in_view[-1] and centre_in_view(camera, near_edge[-1:])[0]  # at rest across the border
    crossing = int(np.argmax(~in_view))
    outs = [e for e in rollout.events if e.kind == "out"]
    assert [(e.bodies, e.frame) for e in outs] == [((0,), crossing)]
    assert not rollout.visible[crossing:, 0].any()


def test_view_events_are_first_visible_and_first_invisible_frames():
    visible = np.array([[True, False], [True, False], [False, True], [False, True], [True, False]])
    active = np.array([[True, True], [True, True], [True, True], [True, True], [True, False]])
    # body 1 becomes inactive (removed) at frame 4: that is not an "out".
    assert view_events(visible, active) == [("out", 0, 2), ("in", 1, 2), ("in", 0, 4)]  # by frame, then body


def test_rollout_reports_in_and_out_when_a_body_crosses_the_image_border():
    camera = overhead_camera()
    world = world_of(body(0, (8.0, 0.0), (4.0, 0.0), friction=0.1), body(1, (-12.0, 2.0), (4.0, 0.0), friction=0.1),
                     fps=25.0, camera=camera)
    rollout = simulate(world, horizon_frames=100)
    outs = [e for e in rollout.events if e.kind == "out"]
    ins = [e for e in rollout.events if e.kind == "in"]
    assert [e.bodies for e in outs] == [(0,)] and [e.bodies for e in ins] == [(1,)]
    k_out, k_in = outs[0].frame, ins[0].frame
    assert rollout.visible[k_out - 1, 0] and not rollout.visible[k_out, 0]
    assert not rollout.visible[k_in - 1, 1] and rollout.visible[k_in, 1]
    assert not rollout.visible[k_out:, 0].any()
