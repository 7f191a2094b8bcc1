"""Friction between objects at impacts: the engine's law against MuJoCo (the generator's contact model).

One object launched at a resting one, off-centre (bench/pair_mujoco.py: the
generator's own MJCF and simulation), and the same scene in our engine with
the generator's parameters: spheres sliding at their rolling deceleration
without friction between bodies (identification's default before), rolling
spheres with frictionless contact, rigid Coulomb
with the sticking limit (slip removal 1), and the share of the slip that
MuJoCo's soft contact removes (``--slip-removal``, the value identification
uses). Printed per case: the direction error (degrees) of the struck and the
striking body's velocity 3 frames after the first contact, and the largest
planar error (cm) of either body over the run; then the cubes' yaw rates
against MuJoCo's (spin from off-centre impacts).

    MUJOCO_GL=egl python -m bench.bench_contact_friction [--seconds 2] [--slip-removal 0.45]
"""

from __future__ import annotations

import argparse

import numpy as np

from bench.pair_mujoco import direction_error_deg, engine_world, pair_spec, run_pair
from world.identify.fit import FitConfig
from world.rollout import simulate

# (shapes, sliding frictions, launch speed m/s): the generator's materials
# (spheres 0.3-0.5, cubes and cylinders 0.045-0.11).
CASES = [
    (("sphere", "sphere"), (0.4, 0.4), 2.0),
    (("sphere", "sphere"), (0.35, 0.45), 1.5),
    (("sphere", "cylinder"), (0.4, 0.08), 2.0),
    (("sphere", "cube"), (0.4, 0.08), 2.0),
    (("cylinder", "sphere"), (0.08, 0.4), 2.0),
    (("cylinder", "cylinder"), (0.08, 0.08), 2.0),
    (("cube", "cube"), (0.08, 0.08), 2.0),
]
OFFSETS = (0.1, 0.2, 0.3)  # m, sideways offset of the resting object (contact distance 0.4 m)


def case_errors(shapes, frictions, speed, offset, seconds, models) -> dict[str, tuple[float, float, float]]:
    """Per model name: (struck direction error deg, striker direction error deg, max planar error m)."""
    spec = pair_spec(shapes, speed, offset, frictions)
    truth = run_pair(spec, seconds)
    frames = truth.positions.shape[0]
    if not truth.collisions:
        return {}
    probe = truth.collisions[0].frame + 3
    out = {}
    for name, (friction_on, removal, rolling) in models.items():
        ours = simulate(engine_world(spec, frames, friction_on, removal, rolling), horizon_frames=frames)
        errors = np.linalg.norm(ours.positions[:, :, :2] - truth.positions[:, :, :2], axis=2)
        out[name] = (direction_error_deg(ours.velocities[probe, 1, :2], truth.velocities[probe, 1, :2]),
                     direction_error_deg(ours.velocities[probe, 0, :2], truth.velocities[probe, 0, :2]),
                     float(errors.max()))
    return out


def spin_rates(shapes, frictions, speed, offset, seconds, model) -> list[tuple[str, float, float]]:
    """Per cube of the case: (role, MuJoCo's yaw rate, ours) in rad/s, 3 frames after MuJoCo's first contact.

    Ours from the yaw by a central difference over one frame each side (the same for any engine version).
    """
    spec = pair_spec(shapes, speed, offset, frictions)
    truth = run_pair(spec, seconds)
    if not truth.collisions:
        return []
    frames = truth.positions.shape[0]
    probe = truth.collisions[0].frame + 3
    ours = simulate(engine_world(spec, frames, *model), horizon_frames=frames)
    rates = (ours.yaw[probe + 1] - ours.yaw[probe - 1]) * spec.fps / 2.0
    return [(("striker", "struck")[k], float(truth.angular_velocities[probe, k, 2]), float(rates[k]))
            for k, shape in enumerate(shapes) if shape == "cube"]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seconds", type=float, default=2.0)
    parser.add_argument("--slip-removal", type=float, default=FitConfig().contact_slip_removal)
    args = parser.parse_args(argv)
    # (friction between bodies, slip removal, rolling spheres); the first row is the
    # sliding-sphere model identification used by default before.
    models = {"sliding spheres, frictionless": (False, 1.0, False),
              "frictionless": (False, 1.0, True), "Coulomb, sticking": (True, 1.0, True),
              f"Coulomb, removal {args.slip_removal:g}": (True, args.slip_removal, True)}
    print(f"{'pair':<18} {'mu':>9} {'v':>4} {'offset':>6} | " + " | ".join(f"{m[:26]:<26}" for m in models))
    print(f"{'':<18} {'':>9} {'':>4} {'':>6} | " + " | ".join(f"{'struck  striker  max cm':<26}" for _ in models))
    totals = {m: [] for m in models}
    for shapes, frictions, speed in CASES:
        for offset in OFFSETS:
            row = case_errors(shapes, frictions, speed, offset, args.seconds, models)
            if not row:
                continue
            cells = []
            for m in models:
                struck, striker, worst = row[m]
                totals[m].append((abs(struck), abs(striker), worst))
                cells.append(f"{struck:>6.1f} {striker:>8.1f} {worst * 100:>7.1f}   ")
            print(f"{'-'.join(shapes):<18} {frictions[0]:>4.2f}/{frictions[1]:<4.2f} {speed:>4.1f} {offset:>6.2f} | " + " | ".join(cells))
    print("median |struck deg| |striker deg| max cm, and the worst case:")
    for m, values in totals.items():
        v = np.array(values)
        print(f"  {m:<30} {np.median(v[:, 0]):>6.1f} {np.median(v[:, 1]):>6.1f} {np.median(v[:, 2]) * 100:>6.1f}   "
              f"worst {v[:, 0].max():.1f} deg, {v[:, 1].max():.1f} deg, {v[:, 2].max() * 100:.1f} cm")
    last = list(models)[-1]
    print(f"cubes' yaw rate 3 frames after the first contact (rad/s), model '{last}': MuJoCo / ours")
    misses = []
    for shapes, frictions, speed in CASES:
        if "cube" not in shapes:
            continue
        for offset in OFFSETS:
            rows = spin_rates(shapes, frictions, speed, offset, args.seconds, models[last])
            misses += [abs(ours - truth) for _, truth, ours in rows]
            cells = "  ".join(f"{role} {truth:+.2f} / {ours:+.2f}" for role, truth, ours in rows)
            print(f"  {'-'.join(shapes):<18} offset {offset:.2f}  {cells}")
    if misses:
        print(f"  |ours - MuJoCo| median {np.median(misses):.2f} rad/s, max {max(misses):.2f} rad/s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
