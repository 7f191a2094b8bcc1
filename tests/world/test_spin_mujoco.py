"""Spin from off-centre impacts and the coupled slide-and-spin, against MuJoCo.

Ground truth is MuJoCo running the scene generator's own model
(bench/pair_mujoco.py: pair friction the mean of the two sliding
coefficients, soft spring-damper contacts); our side is the engine with the
same parameters and friction between bodies (identification's slip share).
These launches (speeds, offsets, yaws, frictions) are not among
bench/bench_contact_friction.py's cases, which were looked at while building the law.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from bench.pair_mujoco import direction_error_deg, engine_world, lone_spec, pair_spec, run_pair, run_spinning
from synth.scene import OBJECT_HALF_SIZE
from world.identify.fit import FitConfig
from world.rollout import simulate
from world.types import Body, BodyState, Shape, World

SECONDS = 2.0


def _impact(shapes, frictions, speed, offset, yaws):
    """MuJoCo's and our rollout of one launch, and the probe frame 3 frames after MuJoCo's first contact."""
    spec = pair_spec(shapes, speed, offset, frictions, yaws=yaws)
    truth = run_pair(spec, SECONDS)
    assert truth.collisions, "the launch must produce a collision in MuJoCo"
    frames = truth.positions.shape[0]
    ours = simulate(engine_world(spec, frames, True, FitConfig().contact_slip_removal, True), horizon_frames=frames)
    return truth, ours, truth.collisions[0].frame + 3


# (shapes, frictions, speed m/s, offset m, yaws rad): a face hit off the centre line, and corner hits.
CASES = {
    "cube-cube face, off-centre": (("cube", "cube"), (0.06, 0.1), 1.6, 0.25, (0.0, 0.0)),
    "cube corner into a cube's face": (("cube", "cube"), (0.09, 0.07), 1.8, 0.12, (math.pi / 4 + 0.1, 0.0)),
    "cube face into a cube's corner": (("cube", "cube"), (0.08, 0.06), 1.7, -0.05, (0.0, math.pi / 4 - 0.2)),
}


@pytest.mark.parametrize("name", list(CASES))
def test_off_centre_impacts_spin_the_cubes_like_mujoco(name):
    shapes, frictions, speed, offset, yaws = CASES[name]
    truth, ours, probe = _impact(shapes, frictions, speed, offset, yaws)
    mujoco_rates = truth.angular_velocities[probe, :, 2]
    our_rates = ours.yaw_rates[probe]
    print(name, "yaw rates MuJoCo", mujoco_rates.round(2), "ours", our_rates.round(2))
    for k, shape in enumerate(shapes):
        if shape != "cube" or abs(mujoco_rates[k]) < 0.5:
            continue
        # The cube's spin: same sense, within 35 % of MuJoCo's (observed: within 15 %).
        assert math.copysign(1.0, our_rates[k]) == math.copysign(1.0, mujoco_rates[k])
        assert abs(our_rates[k] - mujoco_rates[k]) < 0.35 * abs(mujoco_rates[k])
    assert any(shape == "cube" and abs(mujoco_rates[k]) >= 0.5 for k, shape in enumerate(shapes))
    struck = direction_error_deg(ours.velocities[probe, 1, :2], truth.velocities[probe, 1, :2])
    striker = direction_error_deg(ours.velocities[probe, 0, :2], truth.velocities[probe, 0, :2])
    worst = float(np.linalg.norm(ours.positions[:, :, :2] - truth.positions[:, :, :2], axis=2).max())
    print(name, f"struck {struck:.1f} deg, striker {striker:.1f} deg, max error {worst * 100:.1f} cm")
    assert abs(struck) < 10.0 and abs(striker) < 15.0
    assert worst < 0.25


# (shape, velocity m/s, yaw rate rad/s, friction)
LONE = [("cube", (1.7, -0.4), 5.0, 0.07), ("cube", (0.8, 0.5), -6.0, 0.09)]


@pytest.mark.parametrize("case", range(len(LONE)), ids=["fast slide", "fast spin"])
def test_a_spinning_body_slides_further_like_mujoco(case):
    shape_name, velocity, yaw_rate, friction = LONE[case]
    spec = lone_spec(shape_name, velocity, friction)
    positions, yaw, rates = run_spinning(spec, yaw_rate, 3.0)
    shape = (Shape("cube", half_extent=OBJECT_HALF_SIZE) if shape_name == "cube"
             else Shape("cylinder", radius=OBJECT_HALF_SIZE, half_height=OBJECT_HALF_SIZE))
    frames = positions.shape[0]

    def run(spin: float):
        body = Body(0, shape, BodyState((0.0, 0.0, OBJECT_HALF_SIZE), (*velocity, 0.0), 0.0, spin),
                    mass=1.0, friction=friction, restitution=0.7)
        return simulate(World((body,), fps=spec.fps, observed_frames=frames), horizon_frames=frames)

    coupled, plain = run(yaw_rate), run(0.0)  # plain: the slide without the spin's coupling
    error = float(np.linalg.norm(coupled.positions[:, 0, :2] - positions, axis=1).max())
    error_plain = float(np.linalg.norm(plain.positions[:, 0, :2] - positions, axis=1).max())
    print(shape_name, f"max error coupled {error * 100:.1f} cm, plain slide {error_plain * 100:.1f} cm, "
          f"final yaw MuJoCo {yaw[-1]:.2f} ours {coupled.yaw[-1, 0]:.2f}")
    assert error < 0.08
    assert error < 0.6 * error_plain
    # The spin turns the same way and stops (MuJoCo's turns less: its box stands on four corners).
    assert np.sign(coupled.yaw[-1, 0]) == np.sign(yaw[-1]) and coupled.yaw_rates[-1, 0] == 0.0
