"""``physmind synth``: generate a CLEVRER-style dataset; ``physmind synth contact-sheet``: look at it.

    physmind synth --out DIR --scenes N --seed S [--start-index K] [--workers W] [--looks default|tune|heldout]
                   [--renderer mujoco|povray|blender] [--phrasing shortest|clevrer]
    physmind synth contact-sheet DIR [--scenes 0,1,2] [--frames 0,40,80,127] [--png PATH]
    physmind synth questions DIR --phrasing shortest|clevrer   (rewrite DIR/questions.json from its ground truth)

Heavy imports (MuJoCo, PyAV) happen inside the handlers.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any, Callable, Sequence

from tqdm import tqdm

from physmind.executors import run_jobs as run_executor_jobs


def register(subparsers) -> None:
    parser = subparsers.add_parser(
        "synth",
        help="generate CLEVRER-style scenes with MuJoCo (videos, annotations, ground truth, masks, questions)",
        description="Generate CLEVRER-style scenes with MuJoCo ground truth. Deterministic for a given --seed.",
    )
    parser.add_argument("--out", type=Path, help="output directory (CLEVRER layout)")
    parser.add_argument("--scenes", type=int, help="number of scenes to generate")
    parser.add_argument("--seed", type=int, default=0, help="dataset seed (default 0)")
    parser.add_argument("--start-index", type=int, default=0, help="index of the first scene (default 0)")
    parser.add_argument("--workers", type=int, default=1, help="worker processes (default 1)")
    parser.add_argument("--suite", choices=("clevrer", "physion"), default="clevrer",
                        help="clevrer (default) or physion: the five Physion++ categories, --scenes trials each")
    parser.add_argument(
        "--looks",
        default="default",
        help="appearance family: default (synth-1's look, the fixtures), tune (looks to tune perception on) "
        "or heldout (disjoint looks to evaluate on); see synth/looks.py",
    )
    parser.add_argument(
        "--renderer",
        choices=("mujoco", "povray", "blender"),
        default="mujoco",
        help="mujoco (default: MuJoCo's OpenGL renderer) or povray (POV-Ray 3.7 ray tracer in its own look family, "
        "needs the Debian package povray; masks stay MuJoCo's; see synth/povray.py) or blender (Blender's Cycles "
        "path tracer in its own look family, needs the bpy module: `make render`; see synth/blender.py)",
    )
    parser.add_argument("--phrasing", default="shortest",
                        help="how questions name objects: shortest (default: the shortest unique attributes) or clevrer "
                        "(unique attributes drawn at each mention with CLEVRER's frequencies; see synth/questions.py)")
    parser.set_defaults(handler=run_generate)
    inner = parser.add_subparsers(dest="synth_command", metavar="{contact-sheet,questions}")
    rephrase = inner.add_parser("questions", help="write a dataset's questions.json again from its ground truth, in a phrasing")
    rephrase.add_argument("data", type=Path, help="a directory written by `physmind synth`")
    rephrase.add_argument("--phrasing", default="shortest", help="shortest (default) or clevrer (as for `physmind synth`)")
    rephrase.set_defaults(handler=run_questions)
    sheet = inner.add_parser("contact-sheet", help="tile frames of generated videos into one PNG")
    sheet.add_argument("data", type=Path, help="a directory written by `physmind synth`")
    sheet.add_argument("--scenes", default=None, help="comma-separated scene indices (default: the first 4 videos)")
    sheet.add_argument("--frames", default="0,32,64,96,127", help="comma-separated frame indices (default 0,32,64,96,127)")
    sheet.add_argument("--png", type=Path, default=None, help="output PNG (default DATA/contact_sheet.png)")
    sheet.set_defaults(handler=run_contact_sheet)


def _int_list(text: str, name: str) -> list[int]:
    try:
        values = [int(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise ValueError(f"{name}: expected comma-separated integers, got {text!r}") from None
    if not values or any(v < 0 for v in values):
        raise ValueError(f"{name}: expected non-negative integers, got {text!r}")
    return values


def _one_scene(job: tuple[str, int, int, str, str, int, str]):
    # Lazy: MuJoCo loads in the worker process, after synth/__init__ has set MUJOCO_GL.
    from synth.generate import generate_scene

    out, seed, index, looks, renderer, render_processes, phrasing = job
    return generate_scene(Path(out), seed, index, looks, renderer, render_processes, phrasing)


def _check_phrasing(phrasing: str) -> None:
    from synth.questions import check_phrasing

    check_phrasing(phrasing, "--phrasing")


def run_questions(args: argparse.Namespace) -> int:
    """Rewrite DATA/questions.json from DATA/ground_truth (each scene's seed and index), in ``--phrasing``."""
    import json

    from synth.generate import questions_entry, write_questions

    _check_phrasing(args.phrasing)
    paths = sorted((args.data / "ground_truth").glob("scene_*.json"))
    if not paths:
        raise FileNotFoundError(f"{args.data / 'ground_truth'}: no scene_*.json files (not a `physmind synth` directory)")
    entries = []
    for path in paths:  # every scene is made before anything is written: a bad file fails in one line, the old file intact
        try:
            truth = json.loads(path.read_text())
            entries.append(questions_entry(truth, int(truth["generator"]["seed"]), int(truth["scene_index"]), args.phrasing))
        except (ValueError, KeyError, TypeError, AttributeError) as error:
            raise ValueError(f"{path}: not a ground-truth file of `physmind synth` ({type(error).__name__}: {error})") from None
    target = write_questions(args.data, entries)
    count = sum(len(e["questions"]) for e in entries)
    print(f"wrote {count} questions of {len(entries)} scenes ({args.phrasing} phrasing) to {target}")
    return 0


def run_generate(args: argparse.Namespace) -> int:
    if getattr(args, "suite", "clevrer") == "physion":
        if getattr(args, "renderer", "mujoco") != "mujoco":
            raise ValueError("--renderer: the physion suite renders with MuJoCo only")
        # Lazy: loaded only when this command runs, so `physmind --help` and the other commands start fast.
        from synth.physion.cli import run_physion

        return run_physion(args)
    if args.out is None:
        raise ValueError("--out: required (output directory)")
    if args.out.exists() and not args.out.is_dir():
        raise ValueError(f"--out: {str(args.out)!r} is a file, not a directory")
    if args.scenes is None or args.scenes < 1:
        raise ValueError(f"--scenes: expected an integer >= 1, got {args.scenes!r}")
    if args.start_index < 0:
        raise ValueError(f"--start-index: expected an integer >= 0, got {args.start_index}")
    if args.workers < 1:
        raise ValueError(f"--workers: expected an integer >= 1, got {args.workers}")
    if args.seed < 0:
        raise ValueError(f"--seed: expected an integer >= 0, got {args.seed}")
    # Lazy: loaded only when this command runs, so `physmind --help` and the other commands start fast.
    from synth.looks import LOOK_FAMILIES

    phrasing = getattr(args, "phrasing", "shortest")
    _check_phrasing(phrasing)
    if args.looks not in LOOK_FAMILIES:
        raise ValueError(f"--looks: expected one of {', '.join(LOOK_FAMILIES)}, got {args.looks!r}")
    import synth  # noqa: F401  (sets MUJOCO_GL before mujoco loads)
    from synth.generate import write_questions

    renderer = getattr(args, "renderer", "mujoco")
    if renderer == "povray":
        from synth.povray import povray_path

        povray_path()  # a missing povray fails here, in one line, before any scene is simulated
    elif renderer == "blender":
        from synth.blender import require_bpy

        require_bpy()  # a missing bpy fails here, in one line, before any scene is simulated
    # Fewer scenes than workers: the spare workers ray-trace frames of the same scene.
    scene_workers = min(args.workers, args.scenes)
    render_processes = max(1, args.workers // scene_workers) if renderer in ("povray", "blender") else 1
    args.out.mkdir(parents=True, exist_ok=True)
    jobs = [(str(args.out), args.seed, index, args.looks, renderer, render_processes, phrasing)
            for index in range(args.start_index, args.start_index + args.scenes)]
    results = run_jobs(_one_scene, jobs, scene_workers, "synth", "scene")
    results.sort(key=lambda r: r[1].scene_index)
    path = write_questions(args.out, [entry for entry, _ in results])
    print(summary_table([stats for _, stats in results]))
    print(f"wrote {len(results)} scenes to {args.out} (questions: {path})")
    return 0


def summary_table(stats: list) -> str:
    """Per-scene rows and totals: objects, collisions, enter events, questions, correct share, time."""
    lines = ["scene  objs  coll  fut  in  out  expl  pred  cf  correct/choices  tries  seconds"]
    for s in stats:
        q = s.questions
        lines.append(
            f"{s.scene_index:5d}  {s.objects:4d}  {s.collisions:4d}  {s.future_collisions:3d}  {s.enter_events:2d}  {s.exit_events:3d}"
            f"  {q.get('explanatory', 0):4d}  {q.get('predictive', 0):4d}  {q.get('counterfactual', 0):2d}"
            f"  {s.correct_choices:7d}/{s.total_choices:<7d}  {s.attempts:5d}  {s.seconds:7.2f}"
        )
    if stats:
        n = len(stats)
        total_choices = sum(s.total_choices for s in stats)
        by_type: dict[str, int] = {}
        for s in stats:
            for k, v in s.questions.items():
                by_type[k] = by_type.get(k, 0) + v
        lines.append(
            f"total: {n} scenes, {sum(s.objects for s in stats)} objects (mean {sum(s.objects for s in stats) / n:.2f}), "
            f"{sum(s.collisions for s in stats)} observed collisions (mean {sum(s.collisions for s in stats) / n:.2f}; "
            f"{sum(1 for s in stats if s.collisions >= 2)}/{n} scenes with >= 2), "
            f"{sum(s.future_collisions for s in stats)} future collisions, {sum(s.enter_events for s in stats)} enter events "
            f"({sum(1 for s in stats if s.enter_events > 0)}/{n} scenes), {sum(s.exit_events for s in stats)} exit events"
        )
        lines.append(
            f"questions: {sum(by_type.values())} ({', '.join(f'{k} {v}' for k, v in sorted(by_type.items()))}); "
            f"correct options {sum(s.correct_choices for s in stats)}/{total_choices}"
            f" = {sum(s.correct_choices for s in stats) / max(total_choices, 1):.3f}; "
            f"seconds per scene: mean {sum(s.seconds for s in stats) / n:.2f}, max {max(s.seconds for s in stats):.2f}"
        )
    return "\n".join(lines)


def run_contact_sheet(args: argparse.Namespace) -> int:
    # Lazy: loaded only when this command runs, so `physmind --help` and the other commands start fast.
    from perception.debug import write_png
    from synth.contact_sheet import tile
    from synth.render import read_mp4

    videos = sorted((args.data / "videos").glob("video_*.mp4"))
    if not videos:
        raise FileNotFoundError(f"{args.data / 'videos'}: no video_*.mp4 files")
    if args.scenes is None:
        chosen = videos[:4]
    else:
        chosen = []
        for index in _int_list(args.scenes, "--scenes"):
            path = args.data / "videos" / f"video_{index:05d}.mp4"
            if not path.exists():
                raise FileNotFoundError(f"{path}: no such video")
            chosen.append(path)
    frames = _int_list(args.frames, "--frames")
    images = []
    for path in chosen:
        decoded = read_mp4(path)
        for f in frames:
            if f >= len(decoded):
                raise ValueError(f"--frames: frame {f} is beyond the {len(decoded)} frames of {path.name}")
            images.append(decoded[f])
    png = args.png or (args.data / "contact_sheet.png")
    write_png(png, tile(images, len(frames)))
    print(f"wrote {png} ({len(chosen)} videos x {len(frames)} frames)")
    return 0


def run_jobs(function: Callable[[Any], Any], jobs: Sequence[Any], workers: int, desc: str, unit: str) -> list[Any]:
    """``function(job)`` for every job, in this process (workers == 1) or in ``workers`` spawned
    processes (physmind.executors: spawn, so each loads MuJoCo afresh with no forked GL state, and
    each ends itself when this process dies), with a progress bar. Results come in completion order;
    a failing job stops the run with its error."""
    results = []
    with tqdm(total=len(jobs), desc=desc, unit=unit) as bar:
        for _, result, error in run_executor_jobs(function, [(job,) for job in jobs], workers):
            if error is not None:
                raise error
            results.append(result)
            bar.update(1)
    return results
