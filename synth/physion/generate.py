"""Write a Physion-layout dataset: trials.json, videos/, cameras/, annotations/, ground_truth/.

Trial ``k`` of category ``c`` (index ``c * N + k``) depends only on
(seed, c, k); its wanted label alternates with k (true for even k), so labels
are balanced per category.
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np

from synth.mjcf import TIMESTEP
from synth.physion.categories import SampledTrial, sample_trial
from synth.physion.mujoco_run import render_trial
from synth.physion.spec import CATEGORIES, FPS, QUESTION, TrialSpec
from synth.render import write_mp4
from synth.scene import inside_view
from world.io import camera_to_dict
from world.scene3d.io import static_to_dict
from world.types import STANDARD_GRAVITY

FORMAT_VERSION = "physion-1"


def _r(values, digits: int = 4) -> list[float]:
    return [round(float(v), digits) for v in values]


def annotation_document(sampled: SampledTrial) -> dict:
    """Our CLEVRER-like annotation of the observed frames 0..boundary (curtain frames carry no objects)."""
    trial = sampled.trial
    frames: dict[int, list[dict]] = {f: [] for f in range(trial.boundary_frame + 1)}
    for run in sampled.runs:
        for row, f in enumerate(run.frame_ids):
            if f > trial.boundary_frame:
                break
            visible = inside_view(trial.camera, run.positions[row])
            for k, body_id in enumerate(run.body_ids):
                frames[int(f)].append({
                    "object_id": body_id, "location": _r(run.positions[row, k]), "orientation": _r(run.quaternions[row, k], 5),
                    "velocity": _r(run.velocities[row, k]), "inside_camera_view": bool(visible[k]),
                })
    phases = []
    for n, phase in enumerate(trial.phases):
        last = trial.boundary_frame if n == len(trial.phases) - 1 else phase.last_frame
        phases.append({"frames": [phase.first_frame, last], "static_objects": [static_to_dict(b) for b in phase.static_objects]})
    return {
        "scene_index": trial.index, "video_filename": f"video_{trial.index:05d}.mp4", "category": trial.category,
        "fps": FPS, "prediction_boundary_frame": trial.boundary_frame, "horizon_frames": trial.horizon_frame + 1,
        "object_property": [{"object_id": b.id, "color": b.color, "shape": b.shape, "material": "rubber",
                             "size": b.half_size, "role": b.role} for b in trial.bodies],
        "motion_trajectory": [{"frame_id": f, "objects": objects} for f, objects in frames.items()],
        "curtain_frames": None if trial.curtain_frames is None else list(trial.curtain_frames),
        "phases": phases, "patient_zone": trial.patient_zone,
    }


def _realised(sampled: SampledTrial) -> dict:
    impacts = [(t, e) for run in sampled.runs for t, e in run.impacts]
    return {"impacts": [{"time": round(t, 4), "restitution": round(e, 4)} for t, e in impacts],
            "median": round(float(np.median([e for _, e in impacts])), 4) if impacts else None}


def ground_truth_document(sampled: SampledTrial, seed: int) -> dict:
    trial = sampled.trial
    last = sampled.runs[-1]
    return {
        "scene_index": trial.index, "category": trial.category,
        "generator": {"version": FORMAT_VERSION, "seed": seed, "sampling_attempts": sampled.attempts},
        "physics": {"engine": "mujoco", "mujoco_version": mujoco.__version__, "timestep": TIMESTEP, "gravity": STANDARD_GRAVITY},
        "property": {"kind": trial.property_kind, "object_id": trial.property_body, "value": trial.property_value,
                     "swapped_value": trial.swapped_value},
        "pair_restitution": trial.pair_restitution,
        # restitution trials: what MuJoCo's soft contact did at the agent's static impacts (the property's
        # value above is the contact parameter); the median is robust to grazing hits on edges
        "realised_restitution": _realised(sampled) if trial.property_kind == "restitution" else None,
        "label": sampled.label, "swapped_label": sampled.swapped_label, "label_flips": sampled.label_flips,
        "contact_time": sampled.contact_time,
        "objects": [{"object_id": b.id, "shape": b.shape, "size": b.half_size, "mass": b.mass, "friction": b.friction,
                     "restitution": b.restitution, "role": b.role, "color": b.color} for b in trial.bodies],
        "continuation": {"frame_ids": [int(f) for f in last.frame_ids],
                         "objects": [{"object_id": body_id, "location": [_r(p) for p in last.positions[:, k]]}
                                     for k, body_id in enumerate(last.body_ids)]},
    }


@dataclass(frozen=True)
class TrialStats:
    index: int
    category: str
    label: bool
    label_flips: bool
    attempts: int
    seconds: float


def generate_trial(out: Path, seed: int, category: str, k: int, per_category: int, video: bool = True) -> tuple[dict, TrialStats]:
    """Sample, render and write trial k of ``category``; returns its trials.json entry and stats."""
    start = time.perf_counter()
    c = CATEGORIES.index(category)
    index = c * per_category + k
    sampled = sample_trial(category, np.random.default_rng([seed, c, k]), index, want_label=(k % 2 == 0))
    trial: TrialSpec = sampled.trial
    for sub in ("videos", "cameras", "annotations", "ground_truth"):
        (out / sub).mkdir(parents=True, exist_ok=True)
    if video:
        write_mp4(out / "videos" / f"video_{index:05d}.mp4", render_trial(trial, sampled.runs), FPS)
    (out / "cameras" / f"camera_{index:05d}.json").write_text(json.dumps(camera_to_dict(trial.camera), indent=1))
    (out / "annotations" / f"annotation_{index:05d}.json").write_text(json.dumps(annotation_document(sampled)))
    (out / "ground_truth" / f"trial_{index:05d}.json").write_text(json.dumps(ground_truth_document(sampled, seed)))
    entry = {"index": index, "category": category, "video_filename": f"video_{index:05d}.mp4", "question": QUESTION,
             "label": sampled.label, "label_flips": sampled.label_flips}
    return entry, TrialStats(index, category, sampled.label, sampled.label_flips, sampled.attempts, time.perf_counter() - start)


def write_trials(out: Path, entries: list[dict]) -> Path:
    path = out / "trials.json"
    path.write_text(json.dumps(sorted(entries, key=lambda e: e["index"]), indent=1))
    return path


def summary_table(stats: list[TrialStats]) -> str:
    lines = ["category             trials  true  flips  draws/trial  s/trial"]
    for category in CATEGORIES:
        rows = [s for s in stats if s.category == category]
        if rows:
            lines.append(f"{category:20s} {len(rows):6d} {sum(s.label for s in rows):5d} {sum(s.label_flips for s in rows):6d}"
                         f" {np.mean([s.attempts for s in rows]):12.1f} {np.mean([s.seconds for s in rows]):8.2f}")
    return "\n".join(lines)
