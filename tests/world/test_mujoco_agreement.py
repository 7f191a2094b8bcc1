"""Agreement with an independent engine: the same scenes in MuJoCo 4.0.0 and in world.rollout.

Compared: the order of collision pairs, collision frames (within 2 frames at
25 fps) and final positions (within max(5 cm, 6 % of the travelled distance)). Friction is matched
by construction (MuJoCo's sliding deceleration is mu*g within 0.3 %), the
restitution of MuJoCo's soft contact is measured once per shape pair on a
separate calibration run and given to our engine (see mujoco_scenes.py).
"""

from __future__ import annotations

import dataclasses
from functools import lru_cache

import numpy as np
import pytest

# MuJoCo is a dev dependency (make install): without it these tests fail at import, never skip.
from tests.world.mujoco_scenes import measure_restitution, run_in_mujoco
from tests.world.scenes import CUBE, CYLINDER, body, world_of
from world.rollout import simulate

FPS = 25.0
HORIZON_FRAMES = 75  # 3 s: every scene is at rest well before
FRAME_TOL = 2
# Final positions: within max(5 cm, 6 % of the distance the body travelled in MuJoCo).
# Why 6 %: MuJoCo's soft-contact restitution varies by about +-4 % with impact speed
# (measured 0.77-0.83 for cylinders), and a slide distance goes with speed squared.
FINAL_POSITION_ABS_TOL = 0.05  # m
FINAL_POSITION_REL_TOL = 0.06


@lru_cache(maxsize=None)
def calibrated_restitution(kind_a: str, kind_b: str) -> float:
    """MuJoCo's effective e for a head-on hit of two bodies of these shapes at 2 m/s."""
    shapes = {"cylinder": CYLINDER, "cube": CUBE}
    calibration = world_of(
        body(0, (0.0, 0.0), (2.0, 0.0), shapes[kind_a], friction=0.3),
        body(1, (0.6, 0.0), (0.0, 0.0), shapes[kind_b], friction=0.3), fps=FPS)
    return measure_restitution(calibration)


def with_mujoco_restitution(world):
    pairs = []
    for i, a in enumerate(world.bodies):
        for b in world.bodies[i + 1:]:
            pairs.append((a.id, b.id, calibrated_restitution(*sorted((a.shape.kind, b.shape.kind)))))
    return dataclasses.replace(world, pair_restitution=tuple(pairs))


SCENES = {
    "single_slide_to_rest": world_of(body(0, (0.0, 0.0), (2.0, 0.6), friction=0.3), fps=FPS),
    "head_on": world_of(
        body(0, (-1.0, 0.0), (3.0, 0.0), friction=0.25, mass=1.0),
        body(1, (0.2, 0.0), (-1.0, 0.0), friction=0.25, mass=2.0), fps=FPS),
    "glancing": world_of(
        body(0, (-1.0, 0.25), (3.0, 0.0), friction=0.2),
        body(1, (0.0, 0.0), (0.0, 0.0), friction=0.2), fps=FPS),
    "three_body_chain": world_of(
        body(0, (-1.2, 0.0), (3.5, 0.0), friction=0.2),
        body(1, (-0.3, 0.0), friction=0.2),
        body(2, (0.4, 0.05), friction=0.2), fps=FPS),
    "cube_hit": world_of(
        body(0, (-1.0, 0.0), (3.0, 0.0), CYLINDER, friction=0.25),
        body(1, (0.0, 0.0), (0.0, 0.0), CUBE, friction=0.25, mass=1.5), fps=FPS),
    "cube_on_cube": world_of(
        body(0, (-1.0, 0.02), (2.8, 0.0), CUBE, friction=0.3),
        body(1, (0.0, 0.0), (0.0, 0.0), CUBE, friction=0.3), fps=FPS),
}


@lru_cache(maxsize=None)
def both_runs(name: str):
    world = with_mujoco_restitution(SCENES[name])
    ours = simulate(world, horizon_frames=HORIZON_FRAMES)
    theirs = run_in_mujoco(world, duration=(HORIZON_FRAMES - 1) / FPS)
    return world, ours, theirs


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(SCENES))
def test_collision_order_matches_mujoco(name):
    _, ours, theirs = both_runs(name)
    our_pairs = [e.bodies for e in ours.events if e.kind == "collision"]
    their_pairs = [pair for _, pair in theirs.collisions]
    assert our_pairs == their_pairs


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(SCENES))
def test_collision_frames_within_two_frames(name):
    _, ours, theirs = both_runs(name)
    our_frames = [e.frame for e in ours.events if e.kind == "collision"]
    their_frames = [int(np.floor(t * FPS + 0.5)) for t, _ in theirs.collisions]
    assert len(our_frames) == len(their_frames)
    for ours_f, theirs_f in zip(our_frames, their_frames):
        assert abs(ours_f - theirs_f) <= FRAME_TOL, (our_frames, their_frames)


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(SCENES))
def test_final_positions_within_tolerance(name):
    world, ours, theirs = both_runs(name)
    for k, body_id in enumerate(ours.body_ids):
        start_xy = np.array(world.body(body_id).initial.position[:2])
        ours_xy = ours.positions[-1, k, :2]
        theirs_xy = np.array(theirs.final[body_id])
        tolerance = max(FINAL_POSITION_ABS_TOL, FINAL_POSITION_REL_TOL * np.linalg.norm(theirs_xy - start_xy))
        assert np.linalg.norm(ours_xy - theirs_xy) <= tolerance, (body_id, ours_xy, theirs_xy, tolerance)


@pytest.mark.slow
def test_calibrated_restitution_is_physical():
    # The calibration must give a real bounce, else the agreement tests would test nothing.
    for kinds in (("cylinder", "cylinder"), ("cube", "cylinder"), ("cube", "cube")):
        assert 0.3 < calibrated_restitution(*kinds) < 1.0
