"""Blender Cycles speed and noise at 480x320 on the CPU: samples x denoiser (synth/blender.py).

    MUJOCO_GL=egl nice -n 10 .venv/bin/python -m bench.bench_blender --seed 9393 --scenes 2 --frames 5

For each of ``--scenes`` fresh scenes (seed ``--seed``, held-out looks for camera and objects,
the scene's own Blender look) and each Cycles setting, render the first ``--frames`` frames
in one Blender child process (synth/blender_worker.py, one thread, as `physmind synth
--workers 1` does) and read its timings.json: CPU and wall seconds per frame (median over
frames and scenes) and the one-off set-up (Blender start, scene build). Noise: PSNR of frame
0 against a reference render of the same frame with ``--reference-samples`` samples and the
denoiser (higher is closer to the converged image).
"""

from __future__ import annotations

import argparse
import json
import statistics
import tempfile
from pathlib import Path

import numpy as np

from synth.blender import render_description, scene_blender_look, scene_description
from synth.generate import sample_accepted_scene

SETTINGS = ((1, True), (2, False), (2, True), (4, True), (8, True))  # (samples, OIDN denoiser)


def _render(description: dict) -> tuple[np.ndarray, dict]:
    with tempfile.TemporaryDirectory(prefix="bench-blender-") as tmp:
        frames = render_description(description, Path(tmp))
        return frames, json.loads((Path(tmp) / "timings.json").read_text())


def _psnr(image: np.ndarray, reference: np.ndarray) -> float:
    mse = float(np.mean((image.astype(float) - reference.astype(float)) ** 2))
    return 10.0 * np.log10(255.0**2 / max(mse, 1e-12))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=9393)
    parser.add_argument("--scenes", type=int, default=2)
    parser.add_argument("--frames", type=int, default=5)
    parser.add_argument("--reference-samples", type=int, default=64)
    args = parser.parse_args()
    rows: dict[tuple[int, bool], dict[str, list[float]]] = {s: {"cpu": [], "wall": [], "setup": [], "psnr": []} for s in SETTINGS}
    for index in range(args.scenes):
        spec, sim, _ = sample_accepted_scene(args.seed, index, "heldout")
        look = scene_blender_look(args.seed, index)
        reference, _ = _render(scene_description(spec, sim, look, 1, samples=args.reference_samples, denoise=True))
        for samples, denoise in SETTINGS:
            frames, timings = _render(scene_description(spec, sim, look, args.frames, samples=samples, denoise=denoise))
            row = rows[(samples, denoise)]
            row["cpu"] += [f["cpu_s"] for f in timings["frames"]]
            row["wall"] += [f["wall_s"] for f in timings["frames"]]
            row["setup"].append(timings["setup_cpu_s"])
            row["psnr"].append(_psnr(frames[0], reference[0]))
            print(f"scene {index} samples {samples} denoise {denoise}: cpu/frame {statistics.median(timings['frames'][i]['cpu_s'] for i in range(args.frames)):.2f} s", flush=True)
    print(f"\n{args.scenes} scenes (seed {args.seed}) x {args.frames} frames, 480x320, 1 thread; "
          f"PSNR of frame 0 vs {args.reference_samples} samples + OIDN")
    print("| samples | OIDN denoiser | CPU s / frame (median) | wall s / frame (median) | set-up CPU s | PSNR dB (mean) |")
    print("|---:|---|---:|---:|---:|---:|")
    for (samples, denoise), row in rows.items():
        print(f"| {samples} | {'on' if denoise else 'off'} | {statistics.median(row['cpu']):.2f} | {statistics.median(row['wall']):.2f} "
              f"| {statistics.median(row['setup']):.2f} | {statistics.mean(row['psnr']):.1f} |")


if __name__ == "__main__":
    main()
