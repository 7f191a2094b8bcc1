"""Generate one scene end to end: sample, simulate (factual + counterfactuals), render, write files."""

from __future__ import annotations

import json
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from synth.annotate import (
    annotation_document,
    ground_truth_document,
    program_scene_from_ground_truth,
    proposals_document,
    seen_object_ids,
    video_filename,
)
from synth.looks import look_seed_sequence, sample_look
from synth.blender import render_scene_blender, scene_blender_look
from synth.blender_look import blender_look_document
from synth.povray import render_scene_povray, scene_povray_look
from synth.povray_look import povray_look_document
from synth.questions import scene_questions
from synth.render import render_scene, write_mp4
from synth.scene import CAMERA_TARGET, SceneSpec, sample_scene
from synth.simulate import SimResult, simulate

MAX_ATTEMPTS = 40  # scene draws before settling for the best one
SHARE_NEEDING_TWO_COLLISIONS = 0.9  # most scenes must show >= 2 collisions
SHARE_NEEDING_FUTURE_COLLISION = 0.7  # most scenes need a collision after the video (predictive)
MAX_SANE_SPEED = 8.0  # m/s; faster means a contact blew up: re-draw
MAX_SANE_HEIGHT = 0.45  # m; objects must stay on the floor (centre at 0.2 m)
RENDERERS = ("mujoco", "povray", "blender")  # synth.render (MuJoCo's OpenGL), synth.povray (POV-Ray), synth.blender (Cycles)


@dataclass(frozen=True)
class SceneStats:
    scene_index: int
    objects: int
    collisions: int
    enter_events: int
    exit_events: int
    future_collisions: int
    questions: dict
    correct_choices: int
    total_choices: int
    attempts: int
    seconds: float


def _observed_collisions(sim: SimResult, observed: int) -> int:
    return sum(1 for e in sim.collisions if e.frame < observed)


def _sane(sim: SimResult) -> bool:
    speed = np.linalg.norm(sim.velocities, axis=-1)
    return bool(speed.max() < MAX_SANE_SPEED and sim.positions[..., 2].max() < MAX_SANE_HEIGHT)


def scene_draws(seed: int, index: int, looks: str = "default") -> tuple[int, int, Iterator[SceneSpec]]:
    """The (seed, index) stream: observed and future collisions a scene needs, and its scene draws.

    ``looks`` is the look family (synth.looks); the look is drawn once, from its
    own stream, and kept across the re-draws. The default look's scenes use
    exactly synth-1's stream.
    """
    look = sample_look(np.random.default_rng(look_seed_sequence(seed, index, looks)), looks, CAMERA_TARGET)
    rng = np.random.default_rng(np.random.SeedSequence([seed, index]))
    needed = 2 if rng.uniform() < SHARE_NEEDING_TWO_COLLISIONS else 1
    needed_future = 1 if rng.uniform() < SHARE_NEEDING_FUTURE_COLLISION else 0

    def draws() -> Iterator[SceneSpec]:
        while True:
            yield sample_scene(rng, index, look)

    return needed, needed_future, draws()


def sample_accepted_scene(seed: int, index: int, looks: str = "default") -> tuple[SceneSpec, SimResult, int]:
    """Draw scenes (see scene_draws) until one shows enough collisions."""
    needed, needed_future, draws = scene_draws(seed, index, looks)
    best: tuple[tuple[int, int], SceneSpec, SimResult, int] | None = None
    for attempt in range(1, MAX_ATTEMPTS + 1):
        spec = next(draws)
        sim = simulate(spec)
        if not _sane(sim):
            continue
        count = _observed_collisions(sim, spec.observed_frames)
        future = len(sim.collisions) - count
        if count >= needed and future >= needed_future:
            return spec, sim, attempt
        score = (min(count, needed) + min(future, needed_future), count)
        if best is None or score > best[0]:
            best = (score, spec, sim, attempt)
    if best is None:
        raise RuntimeError(f"scene {index}: no physically sane scene in {MAX_ATTEMPTS} draws")
    return best[1], best[2], MAX_ATTEMPTS


def _dump(path: Path, document: dict, indent: int | None = None) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    separators = (",", ":") if indent is None else (",", ": ")
    path.write_text(json.dumps(document, indent=indent, separators=separators, ensure_ascii=False) + "\n")


def generate_scene(out: Path, seed: int, index: int, looks: str = "default", renderer: str = "mujoco",
                   render_processes: int = 1, phrasing: str = "shortest") -> tuple[dict, SceneStats]:
    """Write the video, annotation, ground truth and masks of scene ``index``
    with a look of family ``looks`` (synth.looks.LOOK_FAMILIES), rendered by
    ``renderer`` (RENDERERS).

    With "povray" the video is ray-traced (``render_processes`` concurrent
    povray runs) in the scene's POV-Ray look (synth.povray_look; camera and
    objects as ``looks`` draws them), the masks stay MuJoCo's segmentation of
    the same geometry, and the ground truth records the look under ``renderer``.
    With "blender" the same holds with Cycles (synth.blender, look of
    synth.blender_look; ``render_processes`` is its thread count).
    ``phrasing`` names the objects of the questions (synth.questions.PHRASINGS).
    Returns the scene's questions.json entry and its statistics.
    """
    if renderer not in RENDERERS:
        raise ValueError(f"renderer: expected one of {', '.join(RENDERERS)}, got {renderer!r}")
    start = time.perf_counter()
    spec, sim, attempts = sample_accepted_scene(seed, index, looks)
    counterfactuals = {o.object_id: simulate(spec, removed=o.object_id) for o in spec.objects}
    ground_truth = ground_truth_document(spec, sim, counterfactuals, seed, attempts)
    annotation = annotation_document(spec, sim)
    rgb, instance = render_scene(spec, sim)
    if renderer == "povray":
        pov_look = scene_povray_look(spec, seed, index)
        rgb = render_scene_povray(spec, sim, pov_look, processes=render_processes)
        ground_truth["renderer"] = {"name": "povray", "look": povray_look_document(pov_look)}
    elif renderer == "blender":
        blender_look = scene_blender_look(seed, index)
        rgb = render_scene_blender(spec, sim, blender_look, threads=render_processes)
        ground_truth["renderer"] = {"name": "blender", "look": blender_look_document(blender_look)}
    write_mp4(out / "videos" / video_filename(index), rgb, spec.fps, spec.look.crf)
    _dump(out / "annotations" / f"annotation_{index:05d}.json", annotation)
    _dump(out / "ground_truth" / f"scene_{index:05d}.json", ground_truth)
    _dump(out / "masks" / f"proposal_{index:05d}.json", proposals_document(spec, instance))

    entry = questions_entry(ground_truth, seed, index, phrasing)
    questions = entry["questions"]

    by_type: dict[str, int] = {}
    for q in questions:
        by_type[q["question_type"]] = by_type.get(q["question_type"], 0) + 1
    choices = [c for q in questions for c in q["choices"]]
    observed = [e for e in sim.events if e.frame < spec.observed_frames]
    stats = SceneStats(
        scene_index=index,
        objects=len(spec.objects),
        collisions=sum(1 for e in observed if e.kind == "collision"),
        enter_events=sum(1 for e in observed if e.kind == "in"),
        exit_events=sum(1 for e in observed if e.kind == "out"),
        future_collisions=sum(1 for e in sim.collisions if e.frame >= spec.observed_frames),
        questions=by_type,
        correct_choices=sum(1 for c in choices if c["answer"] == "correct"),
        total_choices=len(choices),
        attempts=attempts,
        seconds=time.perf_counter() - start,
    )
    return entry, stats


def questions_entry(ground_truth: dict, seed: int, index: int, phrasing: str = "shortest") -> dict:
    """Scene ``index``'s questions.json entry, from its ground truth (stream [seed, index, 1]),
    objects named by ``phrasing`` (synth.questions.PHRASINGS)."""
    question_rng = np.random.default_rng(np.random.SeedSequence([seed, index, 1]))
    questions = scene_questions(program_scene_from_ground_truth(ground_truth), question_rng, seen_object_ids(ground_truth),
                                phrasing)
    return {"scene_index": index, "video_filename": video_filename(index), "questions": questions}


def write_questions(out: Path, entries: list[dict]) -> Path:
    """Merge scene entries into ``out/questions.json`` (CLEVRER validation.json layout), sorted by scene."""
    path = out / "questions.json"
    merged: dict[int, dict] = {}
    if path.exists():
        for entry in json.loads(path.read_text()):
            merged[int(entry["scene_index"])] = entry
    for entry in entries:
        merged[int(entry["scene_index"])] = entry
    _dump(path, [merged[k] for k in sorted(merged)], indent=1)
    return path
