"""Event-driven rollout versus fixed-step integration of the same model.

Scene: 6 upright cylinders on the plane, several collisions, 160 frames at
25 fps (6.36 s). The fixed-step integrator implements the same model (Coulomb
deceleration mu*g that stops a body instead of reversing it, normal impulse
``j = -(1+e)(v_i-v_j).n / (1/m_i+1/m_j)`` when an overlapping pair approaches),
with semi-implicit Euler at the step ``dt``.

Reference for event times: the same fixed-step integrator at dt = 1e-5 s (an
independent discretisation, not our closed form). Reported per method: median
wall time per rollout, and the max / mean absolute error of collision times and
stop times against the reference (events matched in order per pair / body).

Usage: python -m bench.bench_rollout [--repeats 200]
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from world.rollout import simulate
from world.types import Body, BodyState, Shape, World

FPS = 25.0
FRAMES = 160
G = 9.81
RADIUS = 0.2


def bench_world() -> World:
    """6 cylinders, 4 collisions (a chain, a crossing hit, an oblique hit), radius 0.2 m, e = 0.8."""
    shape = Shape("cylinder", radius=RADIUS, half_height=0.1)
    specs = [  # (x, y, vx, vy, mass, mu)
        (-2.5, 0.0, 5.0, 0.0, 1.0, 0.2),
        (-1.2, 0.05, 0.0, 0.0, 1.5, 0.25),
        (0.0, -0.05, 0.0, 0.0, 1.0, 0.3),
        (1.2, 0.1, 0.0, 0.0, 0.8, 0.2),
        (0.3, 2.2, 0.0, -4.0, 1.2, 0.25),
        (2.6, -1.6, -2.67, 3.24, 1.0, 0.3),
    ]
    bodies = tuple(
        Body(k, shape, BodyState((x, y, 0.1), (vx, vy, 0.0)), mass=m, friction=mu, restitution=0.8)
        for k, (x, y, vx, vy, m, mu) in enumerate(specs))
    return World(bodies, fps=FPS, observed_frames=FRAMES)


def fixed_step(world: World, dt: float, duration: float) -> tuple[list[tuple[float, tuple[int, int]]], dict[int, float]]:
    """Semi-implicit Euler of the same model. Returns collisions [(t, pair)] and stop times {id: t}."""
    n = len(world.bodies)
    p = np.array([b.initial.position[:2] for b in world.bodies], dtype=float)
    v = np.array([b.initial.velocity[:2] for b in world.bodies], dtype=float)
    mass = np.array([b.mass for b in world.bodies])
    decel = np.array([b.friction for b in world.bodies]) * G * dt
    radius_sum = 2 * RADIUS
    e = np.array([b.restitution for b in world.bodies])
    ia, ib = np.triu_indices(n, 1)
    collisions: list[tuple[float, tuple[int, int]]] = []
    stops: dict[int, float] = {}
    moving = np.linalg.norm(v, axis=1) > 0
    steps = int(round(duration / dt))
    for step in range(1, steps + 1):
        t = step * dt
        speed = np.linalg.norm(v, axis=1)
        stopping = speed <= decel
        scale = np.where(stopping, 0.0, 1.0 - decel / np.where(speed > 0, speed, 1.0))
        v = v * scale[:, None]
        for k in np.nonzero(stopping & moving)[0]:
            stops[int(k)] = t
        moving = ~stopping
        p = p + v * dt
        d = p[ia] - p[ib]
        dist = np.linalg.norm(d, axis=1)
        hit = np.nonzero(dist < radius_sum)[0]
        for h in hit:
            a, b = ia[h], ib[h]
            normal = d[h] / dist[h]
            vn = (v[a] - v[b]) @ normal
            if vn >= 0:
                continue
            pair_e = min(e[a], e[b])
            j = -(1 + pair_e) * vn / (1 / mass[a] + 1 / mass[b])
            v[a] += j / mass[a] * normal
            v[b] -= j / mass[b] * normal
            moving[a] = moving[b] = True
            stops.pop(int(a), None)
            stops.pop(int(b), None)
            collisions.append((t, (int(a), int(b))))
    return collisions, stops


def event_errors(collisions, stops, reference) -> tuple[str, float, float, float]:
    """Match collisions in order per pair and stops per body; max / mean abs time error (s)."""
    ref_collisions, ref_stops = reference
    errors, mismatched = [], 0
    for pair in {pair for _, pair in ref_collisions} | {pair for _, pair in collisions}:
        ours = [t for t, p in collisions if p == pair]
        theirs = [t for t, p in ref_collisions if p == pair]
        mismatched += abs(len(ours) - len(theirs))
        errors += [abs(a - b) for a, b in zip(ours, theirs)]
    stop_errors = [abs(stops[k] - ref_stops[k]) for k in ref_stops if k in stops]
    mismatched += len(set(ref_stops) ^ set(stops))
    topology = "same" if mismatched == 0 else f"{mismatched} differ"
    return topology, max(errors, default=float("nan")), float(np.mean(errors)) if errors else float("nan"), \
        max(stop_errors, default=float("nan"))


def timed(fn, repeats: int) -> float:
    samples = []
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        samples.append(time.perf_counter() - start)
    return statistics.median(samples)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=200, help="event-driven rollouts to time (median)")
    parser.add_argument("--stepper-repeats", type=int, default=5, help="fixed-step runs to time (median)")
    args = parser.parse_args(argv)

    world = bench_world()
    duration = (FRAMES - 1) / FPS
    rollout = simulate(world, horizon_frames=FRAMES)
    ours_collisions = [(e.time, e.bodies) for e in rollout.events if e.kind == "collision"]
    ours_stops = {e.bodies[0]: e.time for e in rollout.events if e.kind == "stop"}

    print(f"scene: {len(world.bodies)} bodies, {FRAMES} frames at {FPS:g} fps, "
          f"{len(ours_collisions)} collisions, {len(ours_stops)} stops (event-driven)")
    print("reference: the fixed-step integrator of the same model at dt = 1e-5 s ...", flush=True)
    started = time.perf_counter()
    reference = fixed_step(world, 1e-5, duration)
    print(f"  reference run took {time.perf_counter() - started:.1f} s; "
          f"{len(reference[0])} collisions, {len(reference[1])} stops")

    rows = []
    t_event = timed(lambda: simulate(world, horizon_frames=FRAMES), args.repeats)
    rows.append(("event-driven (closed form)", t_event, *event_errors(ours_collisions, ours_stops, reference)))
    for label, dt in (("fixed step dt=1/250 s", 1 / 250), ("fixed step dt=1/1000 s", 1 / 1000)):
        result = fixed_step(world, dt, duration)
        wall = timed(lambda: fixed_step(world, dt, duration), args.stepper_repeats)
        rows.append((label, wall, *event_errors(*result, reference)))

    header = f"| {'method':<28} | {'median ms':>10} | {'x faster':>9} | {'topology':>9} | " \
             f"{'max coll. err s':>15} | {'mean coll. err s':>16} | {'max stop err s':>14} |"
    print(header)
    print("|" + "|".join("-" * (len(cell)) for cell in header.split("|")[1:-1]) + "|")
    slowest = max(r[1] for r in rows)
    for label, wall, topology, max_err, mean_err, stop_err in rows:
        print(f"| {label:<28} | {wall * 1e3:>10.3f} | {slowest / wall:>9.1f} | {topology:>9} | "
              f"{max_err:>15.2e} | {mean_err:>16.2e} | {stop_err:>14.2e} |")
    stepper_1000 = rows[2][1]
    print(f"event-driven speed-up over dt=1/1000 s: {stepper_1000 / t_event:.1f}x "
          f"(target >= 10x); event-driven median {t_event * 1e3:.2f} ms (target < 5 ms)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
