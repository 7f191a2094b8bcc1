"""Each 3D motion law and event of world.scene3d against MuJoCo (the generator's contact model)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from synth.mjcf import CONTACT_HALF_PERIOD
from synth.physion.mujoco_run import run_trial
from synth.physion.spec import FPS, PhaseSpec, TrialSpec
from synth.scene import camera_look_at
from world.scene3d.rollout import simulate3d
from world.scene3d.types import Body3D, Phase3D, State3D, StaticBox, World3D

FLOOR = StaticBox(100, "floor", (0, 0, -0.25), (15, 15, 0.25))
IMPACT = CONTACT_HALF_PERIOD  # the generator's soft contact holds a bouncing body this long


def mujoco_and_engine(bodies, statics, states, frames, orientations=(), pair_restitution=0.5, realised=False):
    """MuJoCo frame positions (F, N, 3) and the engine's positions at the same times, plus both runs.

    realised: give the engine's agent the restitution MuJoCo's soft contact realised at its first
    impact (its nominal parameter maps to a slightly different e), so the laws are tested, not the mapping.
    """
    camera = camera_look_at(np.array([0.0, -7.0, 2.5]), np.array([0.0, 0.0, 0.5]), 40.0)
    phase = PhaseSpec(0, frames, tuple(statics), tuple(states), tuple(orientations))
    trial = TrialSpec("bounce_wall", 0, tuple(bodies), (phase,), None, 1, frames, camera, "restitution", 0,
                      swapped_value=0.5, pair_restitution=pair_restitution)
    run = run_trial(trial)[0]
    if realised:
        bodies = [replace(bodies[0], restitution=run.impacts[0][1]), *bodies[1:]]
    world = World3D(tuple(bodies), (Phase3D(0.0, tuple(statics), tuple(states)),),
                    pair_restitution=(((bodies[0].id, bodies[-1].id), pair_restitution),) if len(bodies) > 1 else ())
    rollout = simulate3d(world, world.phases[0], frames / FPS)
    times = run.frame_ids / FPS
    engine = np.stack([rollout.positions(body_id, times) for body_id in run.body_ids], axis=1)
    return run, rollout, engine


def test_ballistic_flight_and_floor_bounces():
    ball = Body3D(0, "sphere", 0.1, restitution=0.7, role="agent", impact_duration=IMPACT)
    run, rollout, engine = mujoco_and_engine([ball], [FLOOR], [(0, State3D((-1.0, 0, 1.0), (1.2, 0, 1.5)))], 40,
                                            realised=True)
    first_mujoco = run.impacts[0][0]
    first_engine = next(ev.time for ev in rollout.events if ev.kind == "surface")
    assert abs(first_mujoco - first_engine) < 0.006  # one soft-contact onset step or so
    second = [ev.time for ev in rollout.events if ev.kind == "surface"][1]
    before = run.frame_ids / FPS < second
    error = np.linalg.norm(run.positions[before] - engine[before], axis=2).max()
    assert error < 0.03, f"max position error {error:.3f} m up to the second bounce"


def test_bounce_on_a_wall():
    ball = Body3D(0, "sphere", 0.1, restitution=0.6, role="agent", impact_duration=IMPACT)
    wall = StaticBox(101, "wall", (1.0, 0, 0.6), (0.1, 0.8, 0.6))
    run, rollout, engine = mujoco_and_engine([ball], [FLOOR, wall], [(0, State3D((-0.4, 0, 0.6), (3.0, 0, 1.8)))], 30,
                                            realised=True)
    impacts = [ev for ev in rollout.events if ev.kind == "surface"]
    assert impacts[0].static_id == 101 and abs(impacts[0].time - run.impacts[0][0]) < 0.006
    # up to the floor impact after the wall the laws are exact; MuJoCo realises a different e at the
    # floor (0.64 against 0.60 at the wall here), so the later arc drifts by a few centimetres
    before = run.frame_ids / FPS < impacts[1].time
    assert np.linalg.norm(run.positions[before] - engine[before], axis=2).max() < 0.02
    assert np.linalg.norm(run.positions - engine, axis=2).max() < 0.08


def test_sliding_cube_stops_where_coulomb_says():
    cube = Body3D(0, "cube", 0.1, friction=0.3, role="agent")
    run, rollout, engine = mujoco_and_engine([cube], [FLOOR], [(0, State3D((-1.0, 0, 0.1), (2.0, 0, 0)))], 30)
    assert any(ev.kind == "stop" for ev in rollout.events)
    assert abs(run.positions[-1, 0, 0] - engine[-1, 0, 0]) < 0.01
    assert np.abs(run.positions[:, 0, 0] - engine[:, 0, 0]).max() < 0.015


def test_sliding_down_a_ramp_onto_a_platform():
    theta, mu = math.radians(30), 0.2
    quat = (0.0, math.sin(theta / 2), 0.0, math.cos(theta / 2))
    down = np.array([math.cos(theta), 0, -math.sin(theta)])
    normal = np.array([math.sin(theta), 0, math.cos(theta)])
    edge = np.array([0.0, 0.0, 0.3])
    ramp = StaticBox(101, "ramp", edge - (0.7 * down + 0.05 * normal), (0.7, 0.6, 0.05), quat)
    platform = StaticBox(102, "platform", (1.75, 0, 0.15), (1.75, 0.6, 0.15))
    start = edge - 1.0 * down + (0.1 + 5e-4) * normal
    cube = Body3D(0, "cube", 0.1, friction=mu, role="agent")
    run, rollout, engine = mujoco_and_engine([cube], [FLOOR, ramp, platform], [(0, State3D(start))], 60,
                                             orientations=[(0, quat)])
    on_ramp = run.positions[:, 0, 0] < -0.1
    assert np.abs(run.positions[on_ramp, 0] - engine[on_ramp, 0]).max() < 0.01  # g(sin - mu cos) on the ramp
    # Known limit (docs/engine.md): at the kink the engine drops the normal speed (and mu |v_n|) at once,
    # keeping 0.77 of the speed at 30 deg; MuJoCo's cube pivots over its front edge and keeps about 0.69,
    # so it stops short of the engine's prediction
    shortfall = engine[-1, 0, 0] - run.positions[-1, 0, 0]
    assert 0.0 < shortfall < 0.25


def test_body_body_impact_conserves_momentum_with_the_pair_restitution():
    light = Body3D(0, "cube", 0.1, mass=1.0, role="agent")
    heavy = Body3D(2, "cube", 0.1, mass=3.0)
    states = [(0, State3D((-1.0, 0, 0.1), (2.0, 0, 0))), (2, State3D((0.0, 0, 0.1)))]
    run, rollout, engine = mujoco_and_engine([light, heavy], [FLOOR], states, 25, pair_restitution=0.7)
    assert any(ev.kind == "collision" for ev in rollout.events)
    after = rollout.state(2, 0.95).velocity[0], rollout.state(0, 0.95).velocity[0]
    mujoco_after = run.velocities[-1, run.body_ids.index(2), 0], run.velocities[-1, run.body_ids.index(0), 0]
    assert after == pytest.approx(mujoco_after, abs=0.06)
    assert np.linalg.norm(run.positions - engine, axis=2).max() < 0.03
