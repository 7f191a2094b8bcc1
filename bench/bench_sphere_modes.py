"""Per-mode error of the sphere's motion against MuJoCo (docs/engine.md, "Agreement with MuJoCo").

Spheres drawn from the generator's ranges (sliding and rolling friction, radius
0.2 m) are launched on the generator's floor contact in MuJoCo with a random
planar velocity and spin (bench/sphere_mujoco.py); the engine runs the same
launch with the skid-then-roll model and with the plain sliding model at the
rolling deceleration (spheres before the rolling model). Printed per launch
kind: planar position error (cm) over 3 s, median / p90 / max over launches.

    MUJOCO_GL=egl .venv/bin/python -m bench.bench_sphere_modes [--launches 30] [--seed 5]
"""

from __future__ import annotations

import argparse

import numpy as np

from bench.sphere_mujoco import run_sphere, sphere_spec
from synth.scene import GRAVITY, OBJECT_HALF_SIZE, ROLLING_FRICTION_RANGE, SPHERE_SLIDING_FRICTION_RANGE, TORSIONAL_FRICTION, deceleration
from world.rollout import simulate
from world.types import Body, BodyState, Shape, World

DURATION = 3.0  # s
KINDS = ("rolling", "no spin", "random spin")


def _launch(kind: str, rng: np.random.Generator) -> tuple[tuple[float, float], tuple[float, float]]:
    speed, heading = rng.uniform(0.5, 2.5), rng.uniform(0, 2 * np.pi)
    velocity = (speed * np.cos(heading), speed * np.sin(heading))
    if kind == "rolling":
        return velocity, velocity
    if kind == "no spin":
        return velocity, (0.0, 0.0)
    return velocity, tuple(rng.uniform(-1.5, 1.5, size=2))


def _error(velocity, spin, friction, rolling, times, positions, roll_model: bool) -> np.ndarray:
    coefficient = deceleration("sphere", friction, rolling) / GRAVITY
    state = BodyState((0.0, 0.0, OBJECT_HALF_SIZE), (*velocity, 0.0), spin_velocity=spin if roll_model else None)
    body = Body(0, Shape("sphere", radius=OBJECT_HALF_SIZE), state,
                friction=friction if roll_model else coefficient, rolling_friction=coefficient if roll_model else None)
    rollout = simulate(World((body,), observed_frames=len(times)), horizon_frames=len(times))
    return np.linalg.norm(rollout.positions[:, 0, :2] - positions, axis=1)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--launches", type=int, default=30, help="launches per kind")
    parser.add_argument("--seed", type=int, default=5)
    args = parser.parse_args(argv)
    rng = np.random.default_rng(args.seed)
    print(f"{'launch':<12} {'model':<22} {'n':>3} | {'max err med':>11} {'p90':>6} {'max':>6} (cm)")
    for kind in KINDS:
        errors = {True: [], False: []}
        for _ in range(args.launches):
            material = rng.choice(["rubber", "metal"])
            friction = rng.uniform(*SPHERE_SLIDING_FRICTION_RANGE[material])
            rolling = rng.uniform(*ROLLING_FRICTION_RANGE)
            velocity, spin = _launch(kind, rng)
            times, positions, _ = run_sphere(sphere_spec(friction, rolling, TORSIONAL_FRICTION), velocity, spin, DURATION)
            for roll_model in (True, False):
                errors[roll_model].append(_error(velocity, spin, friction, rolling, times, positions, roll_model).max() * 100)
        for roll_model, name in ((True, "skid then roll"), (False, "slide at rolling decel")):
            e = np.array(errors[roll_model])
            print(f"{kind:<12} {name:<22} {len(e):>3} | {np.median(e):>11.2f} {np.percentile(e, 90):>6.2f} {e.max():>6.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
