"""bench_counterfactual_misses: every miss is a pair MuJoCo's re-simulation makes collide and the edited replay
does not, and its cause holds (fixture scene 2: object 1 is never in view, so the world lacks it)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from bench.bench_counterfactual_misses import CAUSES, OFF_METRES, _scene_rows
from bench.metrics import GroundTruth, rollout_collisions
from world.identify.fit import identify
from world.io import world_to_dict
from world.observations import Observations
from world.rollout import simulate
from world.types import Edit

DATA = Path(__file__).resolve().parents[1] / "data" / "synth"


def test_misses_are_counterfactual_pairs_the_replay_lacks_with_their_cause(tmp_path):
    annotation = DATA / "annotations" / "annotation_00002.json"
    truth = GroundTruth.load(DATA / "ground_truth" / "scene_00002.json")
    world, _ = identify(Observations.from_clevrer_annotation(annotation, camera=truth.camera))
    (tmp_path / "world_00002.json").write_text(json.dumps(world_to_dict(world)))
    rows = _scene_rows((annotation, tmp_path, None))
    misses = [r for r in rows if r["kind"] == "miss"]
    assert misses and {r["cause"] for r in misses} <= set(CAUSES)
    bodies = {b.id for b in world.bodies}
    for row in misses:
        pair, removed = tuple(row["pair"]), row["removed"]
        assert any(p == pair and f == row["frame"] for p, f in truth.counterfactual[removed])
        replay = simulate(world, (Edit("remove_object", removed),), truth.observed_frames)
        assert pair not in {p for p, _ in rollout_collisions(replay)}
        if row["cause"] == "not in world":
            assert not set(pair) <= bodies
        else:
            assert set(pair) <= bodies and (row["cause"] == "factual replay off") == (row["factual_error_m"] > OFF_METRES)
    counts = [r for r in rows if r["kind"] == "counts"]
    assert {r["removed"] for r in counts} == set(truth.counterfactual) & bodies and all(np.isfinite(r["mujoco"]) for r in counts)
