"""``physmind fit``: observations (CLEVRER annotation or observations.json) -> world.json."""

from __future__ import annotations

import argparse
import json
from dataclasses import replace
from pathlib import Path

from world.io import load_camera, read_json_file, world_to_dict
from world.observations import Observations


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "fit",
        help="fit an executable world to observed trajectories",
        description="Identify dynamics (initial states, friction, mass ratios, restitution) "
        "from a CLEVRER annotation or a perception observations.json, and write a world document.",
    )
    parser.add_argument("observations", type=Path, help="annotation_XXXXX.json or observations.json")
    parser.add_argument("-o", "--output", type=Path, required=True, help="world.json to write")
    parser.add_argument("--camera", type=Path, help="camera JSON (intrinsics + pose) for in/out-of-view events")
    parser.add_argument("--report", type=Path, help="also write the fit report here")
    parser.add_argument("--no-joint", action="store_true", help="local closed-form fits only (no joint refinement)")
    parser.set_defaults(handler=run)


def load_observations(path: Path, camera_path: Path | None = None):
    """Read either input format; attach the camera file when given."""
    document = read_json_file(path, "observations file")
    camera = load_camera(camera_path) if camera_path is not None else None
    if isinstance(document, dict) and "motion_trajectory" in document:
        return Observations.from_clevrer_annotation(document, camera=camera)
    if isinstance(document, dict) and "objects" in document:
        observations = Observations.from_dict(document)
        if camera is not None:
            observations = replace(observations, camera=camera)
        return observations
    raise ValueError(f"{path}: neither a CLEVRER annotation (motion_trajectory) nor an observations document (objects)")


def run(args: argparse.Namespace) -> int:
    # Lazy: scipy's optimizers take a second to import; the other `physmind` commands start without them.
    from world.identify.fit import FitConfig, identify

    observations = load_observations(args.observations, args.camera)
    world, report = identify(observations, FitConfig(joint=not args.no_joint))
    args.output.parent.mkdir(parents=True, exist_ok=True)
    args.output.write_text(json.dumps(world_to_dict(world), indent=1))
    if args.report:
        args.report.write_text(json.dumps(report.to_dict(), indent=1))
    bodies = {b.id: b for b in world.bodies}
    for item in report.objects:
        body = bodies.get(item.id)
        if body is None:
            print(f"object {item.id}: not in the world ({'; '.join(item.flags)})")
            continue
        speed = (body.initial.velocity[0] ** 2 + body.initial.velocity[1] ** 2) ** 0.5
        label = " ".join(v for v in (body.color, body.material, body.shape.kind) if v)
        defaulted = f" defaulted: {', '.join(item.defaulted)}" if item.defaulted else ""
        print(
            f"object {item.id} ({label}): enters t={body.initial.time:.2f}s speed={speed:.2f}m/s "
            + (f"mu={body.friction:.3f} " if not body.rolls else
               f"rolling mu={body.rolling_friction:.3f} skid mu={body.friction:.3f} ")
            + f"mass={body.mass:.2f} rmse={item.rmse * 100:.1f}cm{defaulted}"
            + (f" ({'; '.join(item.flags)})" if item.flags else "")
        )
    print(
        f"fit: {len(world.bodies)} bodies, {len(report.collisions_used)} collisions used, "
        f"{report.function_evaluations} rollouts, {report.seconds:.2f} s wall ({report.cpu_seconds:.2f} s CPU){' budget exhausted' if report.budget_exhausted else ''}, rmse {report.rmse * 100:.1f}cm -> {args.output}"
    )
    return 0
