"""bench.oracle_dataset writes the same questions as physmind synth: none names an object never seen."""

from __future__ import annotations

import json

import pytest

from bench.oracle_dataset import oracle_scene
from planner.program import execute
from synth.annotate import program_scene_from_ground_truth, seen_object_ids

# Seed 64646 (the issue-13 diagnosis set), scene 5: object 4 is launched into view only after the video.
SEED, INDEX = 64646, 5


@pytest.mark.slow
def test_oracle_questions_name_only_objects_seen_in_the_video(tmp_path):
    entry = oracle_scene(tmp_path, SEED, INDEX)
    truth = json.loads((tmp_path / "ground_truth" / f"scene_{INDEX:05d}.json").read_text())
    scene, seen = program_scene_from_ground_truth(truth), seen_object_ids(truth)
    assert {o.id for o in scene.objects} - seen  # the scene has an object the video never shows
    named = set()
    for question in entry["questions"]:
        for program in [question["program"]] + [c["program"] for c in question["choices"]]:
            for start in (k for k, token in enumerate(program) if token == "objects"):
                named.add(execute(program[start: program.index("unique", start) + 1], scene).id)
    assert named and named <= seen
