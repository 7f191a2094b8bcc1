"""Speed of the POV-Ray renderer (synth/povray.py): CPU seconds per 480x320 frame.

Usage:
  MUJOCO_GL=egl nice -n 10 python -m bench.bench_povray [--seed 8808] [--scenes 3] [--frames 32] [--looks heldout]

Per scene (drawn as `physmind synth --renderer povray` draws it): POV-Ray look,
floor kind, lights (A = area light, P = point light), frames rendered with one
single-threaded povray, CPU seconds of the povray processes per frame (their
user + system time, which the machine's load does not inflate) and wall
seconds per frame (which it does). The table ends with the mean and max.
"""

from __future__ import annotations

import argparse
import resource
import time

from synth.generate import sample_accepted_scene
from synth.povray import render_scene_povray, scene_povray_look


def _children_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=8808, help="dataset seed (default 8808: no fixture or tuning uses it)")
    parser.add_argument("--scenes", type=int, default=3)
    parser.add_argument("--frames", type=int, default=32, help="frames per scene (default 32)")
    parser.add_argument("--looks", default="heldout", help="synth.looks family of camera and scene (default heldout)")
    args = parser.parse_args(argv)
    rows = ["scene  floor     lights  metal  frames  cpu s/frame  wall s/frame"]
    cpu_per_frame = []
    for index in range(args.scenes):
        spec, sim, _ = sample_accepted_scene(args.seed, index, args.looks)
        look = scene_povray_look(spec, args.seed, index)
        cpu_before, wall_before = _children_cpu(), time.perf_counter()
        render_scene_povray(spec, sim, look, frames=args.frames, processes=1)
        cpu = (_children_cpu() - cpu_before) / args.frames
        wall = (time.perf_counter() - wall_before) / args.frames
        cpu_per_frame.append(cpu)
        lights = "".join("A" if light.area_size > 0 else "P" for light in look.lights)
        metals = sum(1 for o in spec.objects if o.material == "metal")
        rows.append(f"{index:5d}  {look.floor.kind:8s}  {lights:6s}  {metals}/{len(spec.objects)}    {args.frames:6d}  {cpu:11.3f}  {wall:12.3f}")
    rows.append(f"cpu s per frame: mean {sum(cpu_per_frame) / len(cpu_per_frame):.3f}, max {max(cpu_per_frame):.3f} "
                f"({spec.camera.width}x{spec.camera.height})")
    print("\n".join(rows))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
