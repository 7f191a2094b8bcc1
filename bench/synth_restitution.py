"""Realised vs nominal coefficient of restitution of MuJoCo impacts in the generator's
contact model (prints a table; no assertions).

    .venv/bin/python bench/synth_restitution.py
"""

from __future__ import annotations

import numpy as np

from synth.scene import OBJECT_HALF_SIZE, ObjectSpec, SceneSpec, sample_camera
from synth.simulate import simulate


def measure(shape_a: str, shape_b: str, speed: float, restitution: float, yaw: float) -> float:
    camera = sample_camera(np.random.default_rng(0))

    def make(i, shape, x, vx, mass, yaw_i):
        friction = 0.4 if shape == "sphere" else 0.06
        rolling = 0.015 if shape == "sphere" else 0.0
        return ObjectSpec(i, ("red", "blue")[i], "rubber", shape, (x, 0.4, OBJECT_HALF_SIZE), (vx, 0.0, 0.0), yaw_i, mass, friction, rolling, 0.01 if shape == "sphere" else 0.0, restitution, "moving")

    spec = SceneSpec(0, camera, (make(0, shape_a, -1.0, speed, 50.0, 0.0), make(1, shape_b, 0.0, 0.0, 150.0, yaw)), observed_frames=30, future_frames=0)
    result = simulate(spec)
    hit = result.collisions[0]
    before = result.velocities[hit.frame - 1, :, 0]
    after = result.velocities[hit.frame + 2, :, 0]
    return float(-(after[1] - after[0]) / (before[1] - before[0]))


def main() -> None:
    print("pair                 speed  yaw   " + "  ".join(f"e={e:.2f}" for e in (0.55, 0.7, 0.85)))
    for a, b in [("cube", "cube"), ("sphere", "sphere"), ("cylinder", "cylinder"), ("cube", "cylinder"), ("sphere", "cube")]:
        for speed in (1.0, 2.0):
            for yaw in (0.0, 0.4):
                values = [measure(a, b, speed, e, yaw) for e in (0.55, 0.7, 0.85)]
                print(f"{a + '-' + b:20s} {speed:5.1f}  {yaw:3.1f}   " + "  ".join(f"{v:6.2f}" for v in values))


if __name__ == "__main__":
    main()
